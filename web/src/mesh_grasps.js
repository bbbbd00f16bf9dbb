// The mesh panel: upload a mesh file, POST /v1/meshes/grasps (format=json), and see the mesh
// resting on the table in each stable pose with its grasps in 3D, a table of the poses and one of
// the grasps. The page reads the uploaded file itself (three.js loaders) and multiplies it by the
// answer's mesh.scale_applied, so it is drawn in the frame the grasps are in (O, metres).

import { call, describeError } from './api.js';
import {
  graspRows, lengthText, meshFileFormat, meshQuery, meshScale, meshSummary, poseRows,
} from './mesh_grasps_model.js';
import {
  acceptDroppedFile, clearError, fileSizeText, numberField, saveBlob, setDownload, showError,
  whileBusy,
} from './ui.js';

function readFields(root) {
  const n = (id) => numberField(root.querySelector(id));
  return {
    unit: root.querySelector('#mesh-unit').value,
    num_grasps: n('#mesh-num-grasps'),
    robust_samples: n('#mesh-robust-samples'),
    seed: n('#mesh-seed'),
    friction_coefficient: n('#mesh-friction'),
    rescale: root.querySelector('#mesh-rescale').checked,
  };
}

/** Rows with a radio button first (keyboard: Tab to the group, arrows to move) and cells after. */
function fillTable(tbody, rows, name, label, selected, onSelect) {
  tbody.replaceChildren();
  rows.forEach((cells, i) => {
    const row = document.createElement('tr');
    const pick = document.createElement('td');
    const radio = document.createElement('input');
    radio.type = 'radio';
    radio.name = name;
    radio.value = String(i);
    radio.checked = i === selected;
    radio.setAttribute('aria-label', `${label} ${cells[0]}`);
    radio.addEventListener('change', () => onSelect(i));
    pick.append(radio);
    row.append(pick);
    for (const text of cells) {
      const td = document.createElement('td');
      td.textContent = text;
      td.className = 'num';
      row.append(td);
    }
    row.addEventListener('click', (event) => {
      if (event.target !== radio) radio.click();
    });
    if (i === selected) row.classList.add('selected');
    tbody.append(row);
  });
}

function markSelected(tbody, selected) {
  [...tbody.rows].forEach((row, i) => {
    row.classList.toggle('selected', i === selected);
    row.querySelector('input').checked = i === selected;
  });
}

export function mountMeshPanel(root, info) {
  const form = root.querySelector('#mesh-form');
  const fileInput = root.querySelector('#mesh-file');
  const drop = root.querySelector('#mesh-drop');
  const progress = root.querySelector('#mesh-progress');
  const errorBox = root.querySelector('#mesh-error');
  const results = root.querySelector('#mesh-results');
  const canvas = root.querySelector('#mesh-canvas');
  const figure = root.querySelector('#mesh-figure');
  const note = root.querySelector('#mesh-preview-note');
  const poseSelect = root.querySelector('#mesh-pose');
  const drawInput = root.querySelector('#mesh-draw');
  const poseBody = root.querySelector('#mesh-pose-table tbody');
  const graspBody = root.querySelector('#mesh-grasp-table tbody');
  const friction = info && info.defaults && info.defaults.gripper
    && info.defaults.gripper.friction_coefficient;
  if (typeof friction === 'number') root.querySelector('#mesh-friction').value = friction;

  const state = { result: null, pose: 0, selected: -1 };
  let view = null; // created on first use: three.js loads only when a mesh is shown

  const redraw = () => {
    if (!view || !view.result) return;
    const count = Math.max(0, numberField(drawInput) || 0);
    view.update({ pose: state.pose, count, selected: state.selected });
    root.querySelector('#mesh-grid').textContent = `grid ${lengthText(view.gridStep)}`;
  };
  const selectGrasp = (i) => {
    state.selected = i;
    markSelected(graspBody, i);
    root.dataset.selectedGrasp = String(i);
    redraw();
  };
  const selectPose = (i) => {
    state.pose = i;
    poseSelect.value = String(i);
    markSelected(poseBody, i);
    root.dataset.pose = String(i);
    fillTable(graspBody, graspRows(state.result, state.result.stable_poses[i].index ?? i),
      'mesh-grasp', 'Highlight grasp', state.selected, selectGrasp);
    redraw();
  };
  poseSelect.addEventListener('change', () => selectPose(Number(poseSelect.value)));
  drawInput.addEventListener('input', redraw);
  root.querySelector('#mesh-reset-view').addEventListener('click', () => view && view.resetView());
  root.querySelector('#mesh-download-view').addEventListener('click', () => {
    canvas.toBlob((blob) => blob && saveBlob(blob, 'mesh-grasps-view.png'), 'image/png');
  });

  const describeFile = () => {
    const file = fileInput.files[0];
    root.querySelector('#mesh-file-name').textContent =
      file ? `${file.name} (${fileSizeText(file.size)})` : '';
  };
  acceptDroppedFile(drop, fileInput, describeFile);

  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    clearError(errorBox);
    const file = fileInput.files[0];
    if (!file) {
      showError(errorBox, 'Choose a mesh file first (OBJ, PLY or STL).');
      fileInput.focus();
      return;
    }
    const fields = readFields(root);
    try {
      await whileBusy(form, progress, async () => {
        const bytes = await file.arrayBuffer();
        const json = await call(`/v1/meshes/grasps?${meshQuery(fields)}`, {
          method: 'POST',
          headers: { 'Content-Type': 'application/octet-stream' },
          body: bytes,
        }).then((r) => r.text());
        const result = JSON.parse(json);
        Object.assign(state, { result, pose: 0, selected: result.grasps.length ? 0 : -1 });
        root.dataset.selectedGrasp = String(state.selected);
        const stem = file.name.replace(/\.[^.]*$/, '') || 'mesh';
        setDownload(root.querySelector('#mesh-download-json'),
          new Blob([json], { type: 'application/json' }), `${stem}-grasps.json`);
        root.querySelector('#mesh-summary').textContent = meshSummary(result, file.name);
        poseSelect.replaceChildren(...poseRows(result).map((cells, i) => {
          const option = document.createElement('option');
          option.value = String(i);
          option.textContent = `Pose ${cells[0]}: ${cells[1]} %, ${cells[3]} usable grasps`;
          return option;
        }));
        fillTable(poseBody, poseRows(result), 'mesh-pose', 'Show pose', 0, selectPose);
        results.hidden = false;
        note.hidden = true;
        figure.hidden = false;
        try {
          const { parseMesh } = await import('./preview.js');
          const { MeshGraspView } = await import('./mesh_view.js');
          const format = meshFileFormat(file.name, result.mesh && result.mesh.format);
          if (!format) throw new Error(`cannot tell the format of ${file.name}`);
          const geometry = parseMesh(bytes, format);
          const scale = meshScale(result.mesh, fields.unit);
          geometry.scale(scale, scale, scale);
          canvas.dataset.scale = String(scale); // for tests and scripts: file units to metres
          if (!view) view = new MeshGraspView(canvas);
          view.load(geometry, result);
        } catch (error) {
          // The tables are still good; say why there is no picture.
          if (view) view.result = null;
          figure.hidden = true;
          note.textContent = `No 3D view: ${error && error.message ? error.message : error}.`;
          note.hidden = false;
        }
        if (result.stable_poses.length) selectPose(0);
        root.dataset.state = 'done'; // for tests and scripts: the results are on screen
      });
    } catch (error) {
      root.dataset.state = 'error';
      showError(errorBox, describeError(error));
    }
  });
}
