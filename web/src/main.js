// Entry point: reads GET /v1/info once, then mounts each panel of the page.
//
// A panel is a <section data-panel="NAME"> in index.html plus a mount function here. The
// stiffness map is part of the grasps panel, shown when info lists a model (docs/web.md).

import './style.css';
import { describeError, fetchInfo } from './api.js';
import { mountFractalsPanel } from './fractals.js';
import { mountGraspsPanel } from './grasps.js';
import { mountMeshPanel } from './mesh_grasps.js';
import { mountRobotPanel } from './robot.js';
import { mountSegmentationPanel } from './segmentation.js';

const PANELS = {
  grasps: mountGraspsPanel,
  segmentation: mountSegmentationPanel,
  fractals: mountFractalsPanel,
  mesh: mountMeshPanel,
  robot: mountRobotPanel,
};

// A file dropped next to a drop zone must not make the browser leave the page to open it.
function guardPageDrops() {
  for (const type of ['dragover', 'drop']) {
    window.addEventListener(type, (event) => {
      if (!event.defaultPrevented) event.preventDefault();
    });
  }
}

async function start() {
  guardPageDrops();
  const status = document.getElementById('service-status');
  let info = null;
  try {
    info = await fetchInfo();
    status.textContent = `Connected: ${info.name} ${info.version}`;
    status.classList.add('ok');
    document.getElementById('service-version').textContent =
      `${info.name} ${info.version} (${info.build && info.build.type})`;
  } catch (error) {
    // The panels still work with the service's defaults; say what went wrong.
    status.textContent = `Service information unavailable: ${describeError(error)}`;
    status.classList.add('bad');
  }
  for (const section of document.querySelectorAll('[data-panel]')) {
    const mount = PANELS[section.dataset.panel];
    if (mount) mount(section, info);
  }
  document.body.dataset.ready = 'true';
}

start();
