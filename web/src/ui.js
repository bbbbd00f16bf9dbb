// Small DOM helpers shared by the panels: busy state, error box, download links, number formats.

/** Shows the progress indicator and disables the form's submit button while `work` runs. */
export async function whileBusy(form, progress, work) {
  const submit = form.querySelector('button[type="submit"]');
  const started = performance.now();
  const text = progress.querySelector('.progress-text');
  const label = text ? text.textContent : '';
  form.setAttribute('aria-busy', 'true');
  if (submit) submit.disabled = true;
  progress.hidden = false;
  // A person waiting wants to see time pass; update once a second, not on every frame.
  const timer = setInterval(() => {
    if (text) text.textContent = `${label} ${Math.round((performance.now() - started) / 1000)} s`;
  }, 1000);
  try {
    return await work();
  } finally {
    clearInterval(timer);
    if (text) text.textContent = label;
    progress.hidden = true;
    if (submit) submit.disabled = false;
    form.removeAttribute('aria-busy');
  }
}

/**
 * Makes `drop` accept a dragged file for the file `input`: highlighted while a file hovers, the
 * dropped file put into the input, then `onFile()` called (as the input's own change does).
 */
export function acceptDroppedFile(drop, input, onFile) {
  input.addEventListener('change', onFile);
  drop.addEventListener('dragover', (event) => {
    event.preventDefault();
    event.dataTransfer.dropEffect = 'copy';
    drop.classList.add('dragging');
  });
  drop.addEventListener('dragleave', () => drop.classList.remove('dragging'));
  drop.addEventListener('drop', (event) => {
    event.preventDefault();
    drop.classList.remove('dragging');
    const file = event.dataTransfer.files[0];
    if (!file) return;
    const list = new DataTransfer();
    list.items.add(file);
    input.files = list.files;
    onFile();
  });
}

export function showError(box, message) {
  box.textContent = message;
  box.hidden = false;
}

export function clearError(box) {
  box.textContent = '';
  box.hidden = true;
}

const objectUrls = new WeakMap();

/** Points a download link at `blob`, releasing the link's previous object URL. */
export function setDownload(anchor, blob, fileName) {
  const previous = objectUrls.get(anchor);
  if (previous) URL.revokeObjectURL(previous);
  const url = URL.createObjectURL(blob);
  objectUrls.set(anchor, url);
  anchor.href = url;
  if (fileName) anchor.download = fileName;
  anchor.removeAttribute('aria-disabled');
}

/** Saves a blob through a temporary link (for things made on demand, like a canvas picture). */
export function saveBlob(blob, fileName) {
  const link = document.createElement('a');
  link.href = URL.createObjectURL(blob);
  link.download = fileName;
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(link.href), 10_000);
}

/** Fixed decimals, or an en dash for missing values. */
export function fixed(value, digits) {
  return typeof value === 'number' && Number.isFinite(value) ? value.toFixed(digits) : '–';
}

/** The value of a number input, or undefined when empty. NaN when it is not a number. */
export function numberField(input) {
  const text = input.value.trim();
  if (text === '') return undefined;
  return Number(text);
}

export function fileSizeText(bytes) {
  if (bytes < 1024) return `${bytes} B`;
  if (bytes < 1024 * 1024) return `${(bytes / 1024).toFixed(1)} KiB`;
  return `${(bytes / (1024 * 1024)).toFixed(1)} MiB`;
}
