// The fractal-meshes panel: parameters, generate, a 3D preview, the statistics and downloads.
//
// Two requests with the same parameters go out together: format=json (the statistics) and the
// chosen file format (the mesh shown and offered for download). Same body, same bytes: the
// service is deterministic, so both describe one mesh.

import { call, describeError, fileNameFromDisposition } from './api.js';
import { clearError, fixed, numberField, setDownload, showError, whileBusy } from './ui.js';

const FORMAT_LABELS = {
  obj: 'OBJ',
  ply_ascii: 'PLY (ASCII)',
  ply_binary: 'PLY (binary)',
  stl_ascii: 'STL (ASCII)',
  stl_binary: 'STL (binary)',
};

/** The request body: every filled-in field; empty ones take the service's defaults. */
export function fractalBody(fields) {
  const body = {};
  if (fields.seed !== undefined) body.seed = fields.seed;
  if (fields.mapsMin !== undefined && fields.mapsMax !== undefined) {
    body.maps = fields.mapsMin === fields.mapsMax ? fields.mapsMin : [fields.mapsMin, fields.mapsMax];
  } else if (fields.mapsMin !== undefined || fields.mapsMax !== undefined) {
    body.maps = fields.mapsMin !== undefined ? fields.mapsMin : fields.mapsMax;
  }
  for (const key of ['points', 'sigma', 'alpha']) {
    if (fields[key] !== undefined) body[key] = fields[key];
  }
  if (fields.openingMm !== undefined) body.scale = { opening_mm: fields.openingMm };
  body.format = fields.format;
  return body;
}

function readFields(root) {
  const n = (id) => numberField(root.querySelector(id));
  return {
    seed: n('#fractal-seed'),
    mapsMin: n('#fractal-maps-min'),
    mapsMax: n('#fractal-maps-max'),
    points: n('#fractal-points'),
    sigma: n('#fractal-sigma'),
    alpha: n('#fractal-alpha'),
    openingMm: n('#fractal-opening'),
    format: root.querySelector('#fractal-format').value,
  };
}

function statRows(stats) {
  const size = (stats.bbox && stats.bbox.size_m) || [];
  return [
    ['Vertices', String(stats.vertices)],
    ['Faces', String(stats.faces)],
    ['Volume', `${fixed(stats.volume_m3 * 1e6, 2)} cm³`],
    ['Size', `${size.map((x) => fixed(x * 1000, 1)).join(' × ')} mm`],
    ['Maps', String(stats.maps)],
    ['Points', String(stats.points)],
    ['Alpha used', `${fixed(stats.alpha_used, 3)}${stats.alpha_raised ? ` (raised from ${fixed(stats.alpha_requested, 3)})` : ''}`],
    ['Pieces dropped', String(stats.pieces_dropped)],
    ['Attempts', String(stats.attempts)],
    ['Time', `${fixed(stats.milliseconds, 0)} ms`],
  ];
}

function showStats(list, stats) {
  list.replaceChildren();
  for (const [name, value] of statRows(stats)) {
    const dt = document.createElement('dt');
    dt.textContent = name;
    const dd = document.createElement('dd');
    dd.textContent = value;
    list.append(dt, dd);
  }
}

export function mountFractalsPanel(root, info) {
  const form = root.querySelector('#fractal-form');
  const progress = root.querySelector('#fractal-progress');
  const errorBox = root.querySelector('#fractal-error');
  const results = root.querySelector('#fractal-results');
  const canvas = root.querySelector('#fractal-canvas');
  const note = root.querySelector('#fractal-preview-note');
  const formats = (info && info.mesh_formats) || Object.keys(FORMAT_LABELS);
  const select = root.querySelector('#fractal-format');
  for (const name of formats) {
    const option = document.createElement('option');
    option.value = name;
    option.textContent = FORMAT_LABELS[name] || name;
    select.append(option);
  }
  const maxPoints = info && info.limits && info.limits.max_fractal_points;
  if (typeof maxPoints === 'number') root.querySelector('#fractal-points').max = String(maxPoints);
  const opening = info && info.defaults && info.defaults.gripper && info.defaults.gripper.opening_stroke_mm;
  if (typeof opening === 'number') root.querySelector('#fractal-opening').value = opening;

  let preview = null; // created on first use: three.js loads only when a mesh is shown
  root.querySelector('#fractal-reset-view').addEventListener('click', () => preview && preview.resetView());

  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    clearError(errorBox);
    const body = fractalBody(readFields(root));
    const post = (format) => call('/v1/fractals', {
      method: 'POST',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify({ ...body, format }),
    });
    try {
      await whileBusy(form, progress, async () => {
        const [statsText, meshResponse] = await Promise.all([
          post('json').then((r) => r.text()),
          post(body.format),
        ]);
        const meshBytes = await meshResponse.arrayBuffer();
        const stats = JSON.parse(statsText);
        const fileName = fileNameFromDisposition(
          meshResponse.headers.get('Content-Disposition'), `fractal.${body.format}`);
        setDownload(root.querySelector('#download-mesh'),
          new Blob([meshBytes], { type: meshResponse.headers.get('Content-Type') || '' }), fileName);
        root.querySelector('#download-mesh').textContent = `Mesh file (${fileName})`;
        setDownload(root.querySelector('#download-stats'),
          new Blob([statsText], { type: 'application/json' }), fileName.replace(/\.[^.]*$/, '.json'));
        showStats(root.querySelector('#fractal-stats'), stats);
        results.hidden = false;
        note.hidden = true;
        try {
          const { MeshPreview, parseMesh } = await import('./preview.js');
          if (!preview) preview = new MeshPreview(canvas);
          preview.show(parseMesh(meshBytes, body.format));
        } catch (error) {
          // The statistics and the file are still good; say why there is no picture.
          note.textContent = `No 3D preview: ${error && error.message ? error.message : error}.`;
          note.hidden = false;
        }
        root.dataset.state = 'done';
      });
    } catch (error) {
      root.dataset.state = 'error';
      showError(errorBox, describeError(error));
    }
  });
}
