// The grasps panel: upload a depth image (plus optional intrinsics and gripper settings), show
// the colour-mapped depth with the grasps drawn over it, the table of grasps and downloads.
//
// Three requests with the same form go out together: JSON (the grasps), format=png&draw=none
// (the depth picture the page draws its own grasps on, so a row can be highlighted) and
// format=png (the service's own overlay picture, offered as a download). When the service has a
// stiffness model (GET /v1/info "models"), a fourth, POST /v1/stiffness format=color with the same
// depth and intrinsics, gives the stiffness map the grasps can be drawn on instead. Once the
// objects panel (src/segmentation.js) has segmented the image, the requests carry its label image
// as the `labels` part (each grasp then names its object, at no extra cost: the service does not
// segment again), and target=ID when an object is picked there. The selected strategy's own
// fields (built from GET /v1/info's strategy_fields) go along; with strategy=deformability a
// fifth request (format=png&draw=none&overlay=deformability with the chosen target) gives the
// segmentation model's deformability map with the target outlined.

import { call, describeError } from './api.js';
import { angleDegrees, graspShape, isDrawable } from './grasp_geometry.js';
import { meanStiffnessText, stiffnessForm, stiffnessModel, strategyChoices } from './stiffness.js';
import { strategyFieldInputs } from './strategy_fields_model.js';
import {
  acceptDroppedFile, clearError, fileSizeText, fixed, saveBlob, setDownload, showError,
  whileBusy,
} from './ui.js';

/** Sent on `document` when the grasp picked in the table changes: detail {grasp, index, source}. */
export const GRASP_SELECTED_EVENT = 'softgrasp:grasp-selected';
/**
 * Sent on `document` by the objects panel when its segmentation or the picked object changes:
 * detail {labels: Blob (16-bit label PNG) or null, target: id or 0}.
 */
export const OBJECTS_EVENT = 'softgrasp:objects';
/** Sent on `document` when the depth image or its intrinsics change (old instances are stale). */
export const DEPTH_CHANGED_EVENT = 'softgrasp:depth-changed';

const BEST_COLOUR = 'rgb(0, 255, 0)'; // as the service's overlay
const OTHER_COLOUR = 'rgb(255, 255, 255)';
const SELECTED_COLOUR = 'rgb(255, 0, 255)';

const GRIPPER_FIELDS = ['opening_stroke_mm', 'finger_width_mm', 'finger_thickness_mm',
  'finger_length_mm'];
const SEARCH_FIELDS = ['top_k', 'num_angles', 'num_height_steps', 'height_step_mm'];
const INTRINSIC_FIELDS = ['fx', 'fy', 'cx', 'cy'];

/** Fills the form's defaults from GET /v1/info. */
function applyDefaults(root, info) {
  const defaults = (info && info.defaults) || {};
  const gripper = defaults.gripper || {};
  for (const name of GRIPPER_FIELDS) {
    if (typeof gripper[name] === 'number') root.querySelector(`#${name}`).value = gripper[name];
  }
  const search = {
    top_k: defaults.top_k,
    num_angles: defaults.num_angles,
    num_height_steps: defaults.num_height_steps,
    height_step_mm: typeof defaults.height_step_m === 'number'
      ? Number((defaults.height_step_m * 1000).toPrecision(6)) : undefined,
  };
  for (const name of SEARCH_FIELDS) {
    if (typeof search[name] === 'number') root.querySelector(`#${name}`).value = search[name];
  }
  const strategy = root.querySelector('#strategy');
  const choices = strategyChoices(info);
  strategy.replaceChildren();
  for (const { value, label } of choices.options) {
    const option = document.createElement('option');
    option.value = value;
    option.textContent = label;
    strategy.append(option);
  }
  strategy.value = choices.selected;
}

/**
 * The selected strategy's own fields (GET /v1/info's strategy_fields): a select preselected
 * with the default for a choice, a number input with the range (the default as placeholder, left
 * empty = the default) for numbers, a text input for a list of numbers. Each sits in a div with
 * id "strategy-field-NAME"; the inputs have the field's name as id.
 */
function renderStrategyFields(root, info) {
  const container = root.querySelector('#strategy-fields');
  const strategy = root.querySelector('#strategy').value;
  const doc = root.ownerDocument || document;
  container.replaceChildren();
  for (const spec of strategyFieldInputs(info, strategy)) {
    const wrapper = doc.createElement('div');
    wrapper.id = `strategy-field-${spec.name}`;
    const label = doc.createElement('label');
    label.htmlFor = spec.name;
    label.textContent = spec.label;
    label.title = spec.doc;
    let input;
    if (spec.input === 'select') {
      input = doc.createElement('select');
      for (const value of spec.options) {
        const option = doc.createElement('option');
        option.value = value;
        option.textContent = value.replace(/_/g, ' ');
        input.append(option);
      }
      if (spec.options.includes(spec.defaultText)) input.value = spec.defaultText;
    } else {
      input = doc.createElement('input');
      input.type = spec.input;
      if (spec.input === 'number') {
        if (typeof spec.min === 'number') input.min = String(spec.min);
        if (typeof spec.max === 'number') input.max = String(spec.max);
        input.step = spec.step;
      }
      input.placeholder = spec.defaultText;
    }
    input.id = spec.name;
    input.name = spec.name;
    input.title = spec.doc;
    input.dataset.strategyField = 'true';
    wrapper.append(label, input);
    container.append(wrapper);
  }
}

const PICTURE_CAPTIONS = {
  depth: 'Depth colour-mapped (near = warm, missing = black);',
  stiffness: 'Stiffness map of the service\'s model (soft blue … hard red, background black);',
  deformability: 'Deformability map of the segmentation model (very soft blue … rigid red, '
    + 'background black), the target object outlined in white;',
};
const LEGEND_ENDS = {
  stiffness: ['soft 0.1', 'hard 1.0'],
  deformability: ['very soft 1.0', 'rigid 0.0'],
};
const PICTURE_LABELS = {
  depth: 'Colour-mapped depth with the grasps drawn over it',
  stiffness: 'Stiffness map with the grasps drawn over it',
  deformability: 'Deformability map with the target outlined and the grasps drawn over it',
};

/** The request form: files and every non-empty field, and the objects' labels and target. */
function buildForm(root, depthFile, objects) {
  const form = new FormData();
  form.append('depth', depthFile, depthFile.name);
  const intrinsics = root.querySelector('#intrinsics-file').files[0];
  if (intrinsics) form.append('intrinsics', intrinsics, intrinsics.name);
  for (const name of [...INTRINSIC_FIELDS, ...GRIPPER_FIELDS, ...SEARCH_FIELDS]) {
    const value = root.querySelector(`#${name}`).value.trim();
    if (value !== '') form.append(name, value);
  }
  form.append('strategy', root.querySelector('#strategy').value);
  for (const input of root.querySelectorAll('#strategy-fields [data-strategy-field]')) {
    const value = input.value.trim();
    if (value !== '') form.append(input.name, value);
  }
  if (objects && objects.labels) {
    form.append('labels', objects.labels, 'labels.png');
    if (objects.target) form.append('target', String(objects.target));
  }
  return form;
}

/**
 * The depth image chosen in the grasps panel with its intrinsics, as a form for another endpoint
 * that takes the same upload (POST /v1/segmentation); null before a depth image is chosen.
 */
export function depthUploadForm(doc) {
  const depthFile = doc.querySelector('#depth-file').files[0];
  if (!depthFile) return null;
  const form = new FormData();
  form.append('depth', depthFile, depthFile.name);
  const intrinsics = doc.querySelector('#intrinsics-file').files[0];
  if (intrinsics) form.append('intrinsics', intrinsics, intrinsics.name);
  for (const name of INTRINSIC_FIELDS) {
    const value = doc.querySelector(`#${name}`).value.trim();
    if (value !== '') form.append(name, value);
  }
  return form;
}

/** Draws a picture (depth or stiffness) and, when asked, the grasps (selected one last, on top). */
function drawPicture(canvas, bitmap, grasps, selected, showGrasps) {
  const ctx = canvas.getContext('2d');
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  ctx.drawImage(bitmap, 0, 0);
  if (!showGrasps) return;
  const order = grasps.map((g, i) => i).filter((i) => i !== selected).reverse();
  if (selected >= 0) order.push(selected);
  for (const i of order) {
    const grasp = grasps[i];
    if (!isDrawable(grasp)) continue;
    const colour = i === selected && selected !== 0 ? SELECTED_COLOUR
      : i === 0 ? BEST_COLOUR : OTHER_COLOUR;
    const emphasised = i === 0 || i === selected;
    drawGrasp(ctx, graspShape(grasp), colour, emphasised);
  }
}

function drawGrasp(ctx, shape, colour, emphasised) {
  ctx.strokeStyle = colour;
  ctx.fillStyle = colour;
  ctx.lineWidth = emphasised ? 3 : 1;
  for (const corners of shape.fingers) {
    ctx.beginPath();
    ctx.moveTo(corners[0][0], corners[0][1]);
    for (const p of corners.slice(1)) ctx.lineTo(p[0], p[1]);
    ctx.closePath();
    if (emphasised) ctx.fill();
    ctx.stroke();
  }
  ctx.beginPath();
  ctx.moveTo(shape.line[0][0], shape.line[0][1]);
  ctx.lineTo(shape.line[1][0], shape.line[1][1]);
  ctx.stroke();
  ctx.beginPath();
  ctx.arc(shape.center[0], shape.center[1], emphasised ? 4 : 2, 0, 2 * Math.PI);
  ctx.fill();
}

function cell(text, className) {
  const td = document.createElement('td');
  td.textContent = text;
  if (className) td.className = className;
  return td;
}

function fillTable(tbody, grasps, selected, onSelect) {
  tbody.replaceChildren();
  grasps.forEach((g, i) => {
    const row = document.createElement('tr');
    row.dataset.rank = String(g.rank);
    const pick = document.createElement('td');
    const radio = document.createElement('input');
    radio.type = 'radio';
    radio.name = 'selected-grasp';
    radio.value = String(i);
    radio.checked = i === selected;
    radio.setAttribute('aria-label', `Highlight grasp ${g.rank}`);
    radio.addEventListener('change', () => onSelect(i));
    pick.append(radio);
    row.append(pick);
    const p = (g.pose && g.pose.position_m) || [];
    const q = (g.pose && g.pose.orientation_wxyz) || [];
    row.append(
      cell(String(g.rank)),
      cell(fixed(g.score, 3), 'num'),
      cell(fixed(g.opening_m * 1000, 1), 'num'),
      cell(fixed(g.grasp_height_m * 1000, 1), 'num'),
      cell(meanStiffnessText(g.mean_stiffness), 'num'),
      cell(fixed(angleDegrees(g.angle_rad), 1), 'num'),
      cell(p.map((x) => fixed(x * 1000, 1)).join(', '), 'num'),
      cell(q.map((x) => fixed(x, 3)).join(', '), 'num'),
      cell(Number.isInteger(g.instance_id) && g.instance_id > 0 ? String(g.instance_id) : '–', 'num'),
    );
    if (i === selected) row.classList.add('selected');
    tbody.append(row);
  });
}

/** The deformability picture's request: the grasps form with the answer's target outlined. */
function deformabilityForm(body, result) {
  const form = new FormData();
  for (const [name, value] of body.entries()) {
    if (name !== 'target') form.append(name, value);
  }
  const target = result.target && Number.isInteger(result.target.id) ? result.target.id : 0;
  if (target > 0) form.append('target', String(target));
  return form;
}

function summaryText(result, fileName) {
  const n = result.grasps.length;
  const image = result.image || {};
  const camera = result.camera || {};
  const missing = fixed((image.missing_fraction || 0) * 100, 1);
  return `${n} grasp${n === 1 ? '' : 's'} in ${fileName}: ${image.width}×${image.height} ` +
    `${image.format}, ${missing} % missing, camera ${camera.source === 'request' ? 'from the request' : 'default'}` +
    ` (f ${fixed(camera.fx, 1)} px), ${fixed(result.timing_ms && result.timing_ms.total, 0)} ms` +
    `${result.strategy ? `, strategy ${result.strategy}` : ''}` +
    `${result.stiffness_model ? ` (model ${result.stiffness_model})` : ''}` +
    `${result.target ? `, target ${Number.isInteger(result.target.id) ? `object ${result.target.id}`
      : 'none found'} (${result.target.policy.replace('_', ' ')})` : ''}.`;
}

export function mountGraspsPanel(root, info) {
  const form = root.querySelector('#grasp-form');
  const depthInput = root.querySelector('#depth-file');
  const drop = root.querySelector('#depth-drop');
  const fileName = root.querySelector('#depth-file-name');
  const progress = root.querySelector('#grasp-progress');
  const errorBox = root.querySelector('#grasp-error');
  const results = root.querySelector('#grasp-results');
  const canvas = root.querySelector('#grasp-canvas');
  const showGrasps = root.querySelector('#show-grasps');
  const tbody = root.querySelector('#grasp-table tbody');
  const pictureChoice = root.querySelector('#picture-choice');
  const pictureCaption = root.querySelector('#picture-caption');
  const legend = root.querySelector('#stiffness-legend');
  const stiffnessDownload = root.querySelector('#download-stiffness');
  const deformabilityDownload = root.querySelector('#download-deformability');
  applyDefaults(root, info);
  renderStrategyFields(root, info);
  root.querySelector('#strategy').addEventListener('change', () => renderStrategyFields(root, info));
  // Fixed for the page's life: info is read once at load.
  const hasStiffness = stiffnessModel(info) !== null;

  // bitmaps: the pictures the grasps can be drawn on ({depth, stiffness}); picture: the one shown.
  const state = {
    grasps: [], bitmaps: {}, picture: 'depth', selected: 0, source: '', objects: null,
  };
  const targetNote = root.querySelector('#grasp-target');
  document.addEventListener(OBJECTS_EVENT, (event) => {
    state.objects = event.detail && event.detail.labels ? event.detail : null;
    const target = state.objects ? state.objects.target : 0;
    targetNote.textContent = target
      ? `Only object ${target} (picked in the objects panel); other objects are obstacles.` : '';
    targetNote.hidden = !target;
  });
  const redraw = () => {
    const picture = state.bitmaps[state.picture] ? state.picture : 'depth';
    const bitmap = state.bitmaps[picture];
    pictureCaption.textContent = PICTURE_CAPTIONS[picture];
    canvas.setAttribute('aria-label', PICTURE_LABELS[picture]);
    legend.hidden = !LEGEND_ENDS[picture];
    if (LEGEND_ENDS[picture]) {
      [root.querySelector('#legend-low').textContent, root.querySelector('#legend-high').textContent]
        = LEGEND_ENDS[picture];
    }
    canvas.dataset.picture = picture; // for tests and scripts: what the canvas shows
    if (bitmap) drawPicture(canvas, bitmap, state.grasps, state.selected, showGrasps.checked);
  };
  // Other panels (the robot's) follow the selection through a document event, not our state.
  const announce = () => {
    const grasp = state.grasps[state.selected] || null;
    document.dispatchEvent(new CustomEvent(GRASP_SELECTED_EVENT, {
      detail: { grasp, index: state.selected, source: state.source },
    }));
  };
  const select = (i) => {
    state.selected = i;
    for (const row of tbody.rows) row.classList.toggle('selected', row.rowIndex - 1 === i);
    redraw();
    announce();
  };
  showGrasps.addEventListener('change', redraw);
  for (const radio of pictureChoice.querySelectorAll('input[type="radio"]')) {
    radio.addEventListener('change', () => {
      if (!radio.checked) return;
      state.picture = radio.value;
      redraw();
    });
  }

  const describeFile = () => {
    const file = depthInput.files[0];
    fileName.textContent = file ? `${file.name} (${fileSizeText(file.size)})` : '';
    document.dispatchEvent(new CustomEvent(DEPTH_CHANGED_EVENT));
  };
  root.querySelector('#intrinsics-file').addEventListener('change', () => {
    document.dispatchEvent(new CustomEvent(DEPTH_CHANGED_EVENT));
  });
  acceptDroppedFile(drop, depthInput, describeFile);

  root.querySelector('#download-view').addEventListener('click', () => {
    canvas.toBlob((blob) => blob && saveBlob(blob, 'grasps-view.png'), 'image/png');
  });

  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    clearError(errorBox);
    const depthFile = depthInput.files[0];
    if (!depthFile) {
      showError(errorBox, 'Choose a depth image first (NPY, 16-bit PNG or float TIFF).');
      depthInput.focus();
      return;
    }
    const body = buildForm(root, depthFile, state.objects);
    try {
      await whileBusy(form, progress, async () => {
        const [json, depthPng, overlayPng, stiffnessPng] = await Promise.all([
          call('/v1/grasps?format=json', { method: 'POST', body }).then((r) => r.text()),
          call('/v1/grasps?format=png&draw=none', { method: 'POST', body }).then((r) => r.blob()),
          call('/v1/grasps?format=png', { method: 'POST', body }).then((r) => r.blob()),
          hasStiffness
            ? call('/v1/stiffness', { method: 'POST', body: stiffnessForm(body, 'color') })
              .then((r) => r.blob())
            : null,
        ]);
        const result = JSON.parse(json);
        const deformabilityPng = result.strategy === 'deformability'
          ? await call('/v1/grasps?format=png&draw=none&overlay=deformability',
            { method: 'POST', body: deformabilityForm(body, result) }).then((r) => r.blob())
          : null;
        const bitmaps = { depth: await createImageBitmap(depthPng) };
        if (stiffnessPng) bitmaps.stiffness = await createImageBitmap(stiffnessPng);
        if (deformabilityPng) bitmaps.deformability = await createImageBitmap(deformabilityPng);
        for (const old of Object.values(state.bitmaps)) old.close();
        Object.assign(state, {
          grasps: result.grasps,
          bitmaps,
          selected: result.grasps.length ? 0 : -1,
          source: depthFile.name,
        });
        const stem = depthFile.name.replace(/\.[^.]*$/, '') || 'depth';
        setDownload(root.querySelector('#download-json'),
          new Blob([json], { type: 'application/json' }), `${stem}-grasps.json`);
        setDownload(root.querySelector('#download-overlay'), overlayPng, `${stem}-grasps.png`);
        setDownload(root.querySelector('#download-depth'), depthPng, `${stem}-depth.png`);
        if (stiffnessPng) setDownload(stiffnessDownload, stiffnessPng, `${stem}-stiffness.png`);
        stiffnessDownload.hidden = !stiffnessPng;
        if (deformabilityPng) {
          setDownload(deformabilityDownload, deformabilityPng, `${stem}-deformability.png`);
        }
        deformabilityDownload.hidden = !deformabilityPng;
        root.querySelector('#picture-stiffness-label').hidden = !stiffnessPng;
        root.querySelector('#picture-deformability-label').hidden = !deformabilityPng;
        pictureChoice.hidden = !stiffnessPng && !deformabilityPng;
        if (!bitmaps[state.picture]) {
          state.picture = 'depth';
          root.querySelector('#picture-depth').checked = true;
        }
        root.querySelector('#grasp-summary').textContent = summaryText(result, depthFile.name);
        fillTable(tbody, state.grasps, state.selected, select);
        results.hidden = false;
        redraw();
        announce();
        root.dataset.state = 'done'; // for tests and scripts: the results are on screen
      });
    } catch (error) {
      root.dataset.state = 'error';
      showError(errorBox, describeError(error));
    }
  });
}
