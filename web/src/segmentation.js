// The objects panel (thesis ch. 5): segments the depth image chosen in the grasps panel with
// POST /v1/segmentation, shows the service's overlay (instances coloured, ids written) and a
// table of the instances; clicking an instance (its row or the picture) makes it the grasp
// target. The grasps panel sends these labels with its requests (so each grasp names its object)
// and target=ID for the picked one.
//
// Two requests go out together: format=json (the table) and format=labels (the 16-bit label
// image, decoded here so a click on the picture finds its instance, and handed to the grasps
// panel as its `labels` part). The overlay is a third, format=overlay.

import { call, describeError } from './api.js';
import { DEPTH_CHANGED_EVENT, OBJECTS_EVENT, depthUploadForm } from './grasps.js';
import {
  decodeLabelsPng, instanceAt, optionalText, segmentationChoices,
} from './segmentation_model.js';
import { clearError, fixed, setDownload, showError, whileBusy } from './ui.js';

/** The overlay picture with the outline of instance `target` (> 0) drawn over it in white. */
function drawOverlay(canvas, bitmap, labels, target) {
  const ctx = canvas.getContext('2d');
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  ctx.drawImage(bitmap, 0, 0);
  if (!target || !labels || labels.width !== bitmap.width || labels.height !== bitmap.height) return;
  const { width, height, ids } = labels;
  const image = ctx.getImageData(0, 0, width, height);
  const at = (u, v) => (u < 0 || v < 0 || u >= width || v >= height ? 0 : ids[v * width + u]);
  for (let v = 0; v < height; v += 1) {
    for (let u = 0; u < width; u += 1) {
      if (ids[v * width + u] !== target) continue;
      // Pixels within 2 px of the instance's edge.
      let edge = false;
      for (let d = -2; d <= 2 && !edge; d += 1) {
        edge = at(u + d, v) !== target || at(u, v + d) !== target;
      }
      if (!edge) continue;
      image.data.set([255, 255, 255, 255], 4 * (v * width + u));
    }
  }
  ctx.putImageData(image, 0, 0);
}

function cell(text, className) {
  const td = document.createElement('td');
  td.textContent = text;
  if (className) td.className = className;
  return td;
}

export function mountSegmentationPanel(root, info) {
  const form = root.querySelector('#segmentation-form');
  const method = root.querySelector('#segmentation-method');
  const progress = root.querySelector('#segmentation-progress');
  const errorBox = root.querySelector('#segmentation-error');
  const results = root.querySelector('#segmentation-results');
  const canvas = root.querySelector('#segmentation-canvas');
  const tbody = root.querySelector('#instance-table tbody');
  const summary = root.querySelector('#segmentation-summary');
  const targetText = root.querySelector('#segmentation-target');
  const clearTarget = root.querySelector('#segmentation-clear-target');

  const choices = segmentationChoices(info);
  method.replaceChildren();
  for (const { value, label } of choices.options) {
    const option = document.createElement('option');
    option.value = value;
    option.textContent = label;
    method.append(option);
  }
  method.value = choices.selected;

  const state = { instances: [], labels: null, labelsBlob: null, target: 0, bitmap: null };
  const showTarget = () => {
    if (state.bitmap) drawOverlay(canvas, state.bitmap, state.labels, state.target);
    for (const row of tbody.rows) row.classList.toggle('selected', Number(row.dataset.id) === state.target);
    for (const radio of tbody.querySelectorAll('input[type="radio"]')) {
      radio.checked = Number(radio.value) === state.target;
    }
    targetText.textContent = state.target
      ? `Grasp target: object ${state.target}. Find grasps above to grasp only it.`
      : 'No grasp target: grasps may be on any object. Click an object to target it.';
    clearTarget.hidden = !state.target;
    root.dataset.target = String(state.target); // for tests and scripts
  };
  // Tells the grasps panel which labels and target its requests carry.
  const announce = () => {
    document.dispatchEvent(new CustomEvent(OBJECTS_EVENT, {
      detail: { labels: state.labels ? state.labelsBlob : null, target: state.target },
    }));
  };
  const setTarget = (id) => {
    state.target = id;
    showTarget();
    announce();
  };
  clearTarget.addEventListener('click', () => setTarget(0));
  canvas.addEventListener('click', (event) => {
    if (!state.labels) return;
    const box = canvas.getBoundingClientRect();
    const u = ((event.clientX - box.left) * canvas.width) / box.width;
    const v = ((event.clientY - box.top) * canvas.height) / box.height;
    const id = instanceAt(state.labels, u, v);
    if (id) setTarget(id);
  });
  // A new depth image: old instances (and their target) no longer apply.
  document.addEventListener(DEPTH_CHANGED_EVENT, () => {
    results.hidden = true;
    if (state.bitmap) state.bitmap.close();
    Object.assign(state, { labels: null, labelsBlob: null, bitmap: null, target: 0 });
    showTarget();
    announce();
  });

  const fillTable = () => {
    tbody.replaceChildren();
    for (const inst of state.instances) {
      const row = document.createElement('tr');
      row.dataset.id = String(inst.id);
      const pick = document.createElement('td');
      const radio = document.createElement('input');
      radio.type = 'radio';
      radio.name = 'target-instance';
      radio.value = String(inst.id);
      radio.setAttribute('aria-label', `Grasp object ${inst.id}`);
      radio.addEventListener('change', () => setTarget(inst.id));
      pick.append(radio);
      row.append(
        pick,
        cell(String(inst.id)),
        cell(fixed(inst.score, 2), 'num'),
        cell(String(inst.area_px), 'num'),
        cell(fixed(inst.top_height_m * 1000, 1), 'num'),
        cell(optionalText(inst.mean_deformability), 'num'),
        cell(optionalText(inst.mean_stiffness), 'num'),
      );
      row.addEventListener('click', (event) => {
        if (event.target !== radio) setTarget(inst.id);
      });
      tbody.append(row);
    }
    showTarget();
  };

  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    clearError(errorBox);
    const upload = depthUploadForm(document);
    if (!upload) {
      showError(errorBox, 'Choose a depth image in the grasps panel first.');
      return;
    }
    upload.append('method', method.value);
    const query = (format) => `/v1/segmentation?format=${format}`;
    try {
      await whileBusy(form, progress, async () => {
        const [json, labelsBlob, overlayBlob] = await Promise.all([
          call(query('json'), { method: 'POST', body: upload }).then((r) => r.text()),
          call(query('labels'), { method: 'POST', body: upload }).then((r) => r.blob()),
          call(query('overlay'), { method: 'POST', body: upload }).then((r) => r.blob()),
        ]);
        const result = JSON.parse(json);
        const labels = await decodeLabelsPng(await labelsBlob.arrayBuffer());
        const bitmap = await createImageBitmap(overlayBlob);
        if (state.bitmap) state.bitmap.close();
        // Ids of an earlier segmentation mean nothing now: no target.
        Object.assign(state, { instances: result.instances, labels, labelsBlob, bitmap, target: 0 });
        announce();
        const n = result.instances.length;
        summary.textContent = `${n} object${n === 1 ? '' : 's'} found by ${result.method === 'model'
          ? 'the learned model' : 'the PCL baseline'} in ${fixed(result.timing_ms.total, 0)} ms.`;
        setDownload(root.querySelector('#download-instances'),
          new Blob([json], { type: 'application/json' }), 'instances.json');
        setDownload(root.querySelector('#download-labels'), labelsBlob, 'labels.png');
        setDownload(root.querySelector('#download-instance-overlay'), overlayBlob, 'objects.png');
        fillTable();
        results.hidden = false;
        root.dataset.state = 'done';
      });
    } catch (error) {
      root.dataset.state = 'error';
      showError(errorBox, describeError(error));
    }
  });
  showTarget();
}
