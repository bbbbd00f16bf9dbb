// The mesh panel in a real browser (Debian's chromium, headless) against the real
// softgrasp-server: upload the Dex-Net bar clamp and a cube written here (in millimetres, rescaled
// to 40 mm), compare the pose and grasp tables with the JSON the API answers for the same request,
// check that the answer's geometry fits the file as the page draws it (file coordinates times
// scale_applied: every pose rests on z = 0, every contact on the surface), see the selected grasp
// drawn in magenta and follow a row click, and see the API's own message for a file that is not a
// mesh. Screenshots go to <build>/tests/web/artifacts/. Run by CTest (tests/web/CMakeLists.txt).
import assert from 'node:assert/strict';
import { mkdtemp, readFile, rm, writeFile } from 'node:fs/promises';
import os from 'node:os';
import path from 'node:path';
import { after, before, describe, it } from 'node:test';

import {
  artifactPath, checkPrerequisites, launchBrowser, paths, readCanvas, startServer, watchConsole,
} from './harness.mjs';

const BAR_CLAMP = path.join(paths.data, 'meshes', 'dexnet_bar_clamp.obj');
const STEP_TIMEOUT_MS = 60_000;
// Columns of the grasp table: Show, Rank, Width, Robust FC, FC, Aligned, Collision-free, Angle.
const GRASP_COLUMNS = 8;

let server;
let base;
let browser;
let folder;

before(async () => {
  checkPrerequisites();
  server = startServer({ stiffnessModel: 'none', segmentationModel: 'none' });
  base = await server.ready;
  browser = await launchBrowser();
  folder = await mkdtemp(path.join(os.tmpdir(), 'softgrasp-mesh-web-'));
});

after(async () => {
  if (browser) await browser.close();
  if (server) await server.stop();
  if (folder) await rm(folder, { recursive: true, force: true });
});

async function openPage() {
  const context = await browser.newContext({ viewport: { width: 1280, height: 900 }, acceptDownloads: true });
  const page = await context.newPage();
  page.setDefaultTimeout(STEP_TIMEOUT_MS);
  const errors = watchConsole(page);
  await page.goto(`${base}/`);
  await page.waitForSelector('body[data-ready="true"]');
  return { context, page, errors };
}

/** The API's answer for the same file and query the page sends, asked from node. */
async function askApi(file, query) {
  const response = await fetch(`${base}/v1/meshes/grasps?${query}`, {
    method: 'POST',
    headers: { 'Content-Type': 'application/octet-stream' },
    body: await readFile(file),
  });
  return { status: response.status, body: await response.json() };
}

const withoutTiming = ({ timing_ms: _, ...rest }) => rest;

/** Vertices and triangles of an OBJ (v and f lines; f may be polygons, v/vt/vn, negative). */
function readObj(text) {
  const vertices = [];
  const triangles = [];
  for (const line of text.split('\n')) {
    const words = line.trim().split(/\s+/);
    if (words[0] === 'v') vertices.push(words.slice(1, 4).map(Number));
    if (words[0] === 'f') {
      const ids = words.slice(1).map((w) => {
        const i = parseInt(w.split('/')[0], 10);
        return i < 0 ? vertices.length + i : i - 1;
      });
      for (let k = 1; k + 1 < ids.length; k += 1) triangles.push([ids[0], ids[k], ids[k + 1]]);
    }
  }
  return { vertices, triangles };
}

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const along = (a, s, d) => [a[0] + s * d[0], a[1] + s * d[1], a[2] + s * d[2]];

/** Distance from p to triangle abc (Ericson, Real-Time Collision Detection, 5.1.5). */
function triangleDistance(p, a, b, c) {
  const ab = sub(b, a);
  const ac = sub(c, a);
  const ap = sub(p, a);
  const d1 = dot(ab, ap);
  const d2 = dot(ac, ap);
  let q;
  if (d1 <= 0 && d2 <= 0) {
    q = a;
  } else {
    const bp = sub(p, b);
    const d3 = dot(ab, bp);
    const d4 = dot(ac, bp);
    const cp = sub(p, c);
    const d5 = dot(ab, cp);
    const d6 = dot(ac, cp);
    const vc = d1 * d4 - d3 * d2;
    const vb = d5 * d2 - d1 * d6;
    const va = d3 * d6 - d5 * d4;
    if (d3 >= 0 && d4 <= d3) q = b;
    else if (d6 >= 0 && d5 <= d6) q = c;
    else if (vc <= 0 && d1 >= 0 && d3 <= 0) q = along(a, d1 / (d1 - d3), ab);
    else if (vb <= 0 && d2 >= 0 && d6 <= 0) q = along(a, d2 / (d2 - d6), ac);
    else if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
      q = along(b, (d4 - d3) / (d4 - d3 + (d5 - d6)), sub(c, b));
    } else {
      const denom = 1 / (va + vb + vc);
      q = along(along(a, vb * denom, ab), vc * denom, ac);
    }
  }
  const d = sub(p, q);
  return Math.sqrt(dot(d, d));
}

/** Rotates v by the unit quaternion [w, x, y, z]. */
function rotate([w, x, y, z], v) {
  const u = [x, y, z];
  const t = [2 * (u[1] * v[2] - u[2] * v[1]), 2 * (u[2] * v[0] - u[0] * v[2]), 2 * (u[0] * v[1] - u[1] * v[0])];
  const ut = [u[1] * t[2] - u[2] * t[1], u[2] * t[0] - u[0] * t[2], u[0] * t[1] - u[1] * t[0]];
  return [v[0] + w * t[0] + ut[0], v[1] + w * t[1] + ut[1], v[2] + w * t[2] + ut[2]];
}

/**
 * The answer's geometry against the file as the page draws it (coordinates times scale): each
 * stable pose puts the lowest point on the table (z = 0) and every contact lies on the surface.
 */
function checkGeometryFitsFile(objText, result) {
  const scale = result.mesh.scale_applied;
  const { vertices, triangles } = readObj(objText);
  const scaled = vertices.map((v) => v.map((x) => x * scale));
  let size = 0;
  for (let k = 0; k < 3; k += 1) {
    const xs = scaled.map((v) => v[k]);
    size = Math.max(size, Math.max(...xs) - Math.min(...xs));
  }
  for (const pose of result.stable_poses) {
    const { position_m: t, orientation_wxyz: q } = pose.table_from_object;
    const lowest = Math.min(...scaled.map((v) => rotate(q, v)[2] + t[2]));
    assert.ok(Math.abs(lowest) < 1e-5 * size,
      `pose ${pose.index}: lowest point at z = ${lowest} m`);
  }
  for (const grasp of result.grasps) {
    for (const contact of grasp.contacts) {
      let nearest = Infinity;
      for (const [a, b, c] of triangles) {
        nearest = Math.min(nearest, triangleDistance(contact.point_m, scaled[a], scaled[b], scaled[c]));
      }
      assert.ok(nearest < 1e-4 * size, `grasp ${grasp.rank}: contact ${nearest} m off the surface`);
    }
  }
}

/** How many pixels of the 3D view differ from its background, and where the magenta ones are. */
async function viewPixels(page) {
  const { width, height, data } = await readCanvas(page, '#mesh-canvas');
  const bg = [data[0], data[1], data[2]];
  let differing = 0;
  let magenta = 0;
  let mx = 0;
  let my = 0;
  for (let i = 0; i < data.length; i += 4) {
    const d = Math.abs(data[i] - bg[0]) + Math.abs(data[i + 1] - bg[1]) + Math.abs(data[i + 2] - bg[2]);
    if (d > 24) differing += 1;
    if (data[i] > 200 && data[i + 1] < 90 && data[i + 2] > 200) {
      magenta += 1;
      mx += (i / 4) % width;
      my += Math.floor(i / 4 / width);
    }
  }
  return {
    differing, total: width * height, magenta, at: magenta ? [mx / magenta, my / magenta] : null,
  };
}

/** The cells of a table's body, without its first (radio) column. */
function tableCells(page, selector) {
  return page.$$eval(`${selector} tbody tr`, (rows) => rows.map((row) =>
    [...row.cells].slice(1).map((td) => td.textContent)));
}

const yesNo = (value) => (value === true ? 'yes' : value === false ? 'no' : '–');
const fixed = (value, digits) => (typeof value === 'number' ? value.toFixed(digits) : '–');

/** The grasp table of pose `pose`, written from the API's JSON independently of the page's code. */
function expectedGraspCells(result, pose) {
  return result.grasps.map((g) => {
    const seen = g.poses.find((p) => p.pose === pose) || {};
    return [String(g.rank), (g.width_m * 1000).toFixed(1), fixed(g.robust_ferrari_canny, 4),
      g.ferrari_canny.toFixed(4), yesNo(seen.aligned), yesNo(seen.collision_free),
      fixed(seen.approach_table_angle_deg, 1)];
  });
}

describe('mesh panel in chromium', () => {
  it('analyses the bar clamp: tables as the API answers, grasps drawn on the mesh', async () => {
    const { context, page, errors } = await openPage();
    await page.setInputFiles('#mesh-file', BAR_CLAMP);
    await page.selectOption('#mesh-unit', 'm');
    await page.fill('#mesh-num-grasps', '30');
    await page.fill('#mesh-robust-samples', '5');
    await page.fill('#mesh-seed', '3');
    await page.click('#mesh-submit');
    await page.waitForSelector('#mesh[data-state="done"]');

    const shown = await page.evaluate(async () =>
      (await fetch(document.querySelector('#mesh-download-json').href)).json());
    const api = await askApi(BAR_CLAMP,
      'format=json&unit=m&num_grasps=30&robust_samples=5&seed=3&friction_coefficient=0.5');
    assert.equal(api.status, 200);
    assert.deepEqual(withoutTiming(shown), withoutTiming(api.body), 'the page sent what the API was asked');
    const result = api.body;
    assert.ok(result.stable_poses.length >= 2, `${result.stable_poses.length} poses`);
    assert.ok(result.grasps.length >= 5, `${result.grasps.length} grasps`);
    assert.equal(result.mesh.format, 'obj');
    assert.equal(result.mesh.scale_applied, 1);
    checkGeometryFitsFile(await readFile(BAR_CLAMP, 'utf8'), result);

    // The tables, written again here from the JSON.
    const poses = await tableCells(page, '#mesh-pose-table');
    assert.deepEqual(poses.map((row) => row.slice(0, 3)), result.stable_poses.map((p) =>
      [String(p.index), (p.probability * 100).toFixed(1), (p.com_height_m * 1000).toFixed(1)]));
    assert.deepEqual(poses.map((row) => row[3]), result.stable_poses.map((p) => String(result.grasps
      .filter((g) => g.poses.some((s) => s.pose === p.index && s.aligned && s.collision_free)).length)));
    assert.deepEqual(await tableCells(page, '#mesh-grasp-table'), expectedGraspCells(result, 0));
    assert.equal(await page.$$eval('#mesh-grasp-table thead th', (th) => th.length), GRASP_COLUMNS);
    assert.match(await page.textContent('#mesh-summary'),
      new RegExp(`^dexnet_bar_clamp\\.obj, obj, .*${result.stable_poses.length} stable poses, ${result.grasps.length} grasps`));

    // The 3D view: the mesh and the table fill a good part of it; grasp 0 is selected (magenta).
    assert.equal(await page.isVisible('#mesh-preview-note'), false);
    assert.equal(await page.getAttribute('#mesh', 'data-selected-grasp'), '0');
    const first = await viewPixels(page);
    assert.ok(first.differing > first.total * 0.05, JSON.stringify(first));
    assert.ok(first.magenta > 20, `selected grasp: ${first.magenta} magenta pixels`);
    await page.screenshot({ path: artifactPath('mesh.png'), fullPage: true });
    await page.locator('#mesh-canvas').screenshot({ path: artifactPath('mesh-view.png') });

    // Clicking the row of another grasp selects it: the magenta moves.
    const other = result.grasps.findIndex((g, i) => i > 0
      && Math.hypot(...g.center_m.map((x, k) => x - result.grasps[0].center_m[k])) > 0.01);
    assert.ok(other > 0, 'a grasp away from the first');
    await page.locator('#mesh-grasp-table tbody tr').nth(other).locator('td').nth(2).click();
    assert.equal(await page.getAttribute('#mesh', 'data-selected-grasp'), String(other));
    assert.equal(await page.$$eval('#mesh-grasp-table tbody tr.selected', (rows) => rows.length), 1);
    const moved = await viewPixels(page);
    assert.ok(moved.magenta > 20, `selected grasp: ${moved.magenta} magenta pixels`);
    assert.ok(Math.hypot(moved.at[0] - first.at[0], moved.at[1] - first.at[1]) > 3,
      `magenta centre ${first.at} -> ${moved.at}`);

    // Another pose, from the selector: its row is marked, the grasp table is that pose's.
    const last = result.stable_poses.length - 1;
    await page.selectOption('#mesh-pose', String(last));
    assert.equal(await page.getAttribute('#mesh', 'data-pose'), String(last));
    assert.equal(await page.$eval('#mesh-pose-table tbody tr.selected td:nth-child(2)',
      (td) => td.textContent), String(result.stable_poses[last].index));
    assert.deepEqual(await tableCells(page, '#mesh-grasp-table'),
      expectedGraspCells(result, result.stable_poses[last].index));
    assert.equal(await page.getAttribute('#mesh', 'data-selected-grasp'), String(other));
    await page.locator('#mesh-canvas').screenshot({ path: artifactPath('mesh-view-pose-last.png') });
    // and back by a click in the pose table
    await page.locator('#mesh-pose-table tbody tr').nth(0).locator('td').nth(2).click();
    assert.equal(await page.inputValue('#mesh-pose'), '0');
    assert.deepEqual(await tableCells(page, '#mesh-grasp-table'), expectedGraspCells(result, 0));
    assert.deepEqual(errors, []);
    await context.close();
  });

  it('converts millimetres and rescales a cube to 40 mm, drawn at the answer\'s scale', async () => {
    // A 30 mm cube with a corner at the origin: the rescale (about the origin) moves it too.
    const corners = [];
    for (const z of [0, 30]) for (const y of [0, 30]) for (const x of [0, 30]) corners.push(`v ${x} ${y} ${z}`);
    const quads = [[1, 3, 4, 2], [5, 6, 8, 7], [1, 2, 6, 5], [3, 7, 8, 4], [1, 5, 7, 3], [2, 4, 8, 6]];
    const faces = quads.flatMap(([a, b, c, d]) => [`f ${a} ${b} ${c}`, `f ${a} ${c} ${d}`]); // outward
    const cube = path.join(folder, 'cube-30mm.obj');
    const text = `${corners.join('\n')}\n${faces.join('\n')}\n`;
    await writeFile(cube, text);

    const { context, page, errors } = await openPage();
    await page.setInputFiles('#mesh-file', cube);
    await page.selectOption('#mesh-unit', 'mm');
    await page.check('#mesh-rescale');
    await page.fill('#mesh-num-grasps', '20');
    await page.fill('#mesh-robust-samples', '0');
    await page.click('#mesh-submit');
    await page.waitForSelector('#mesh[data-state="done"]');
    const api = await askApi(cube,
      'format=json&unit=mm&num_grasps=20&robust_samples=0&seed=0&friction_coefficient=0.5&rescale_min_extent_mm=40');
    assert.equal(api.status, 200);
    const result = api.body;
    const shown = await page.evaluate(async () =>
      (await fetch(document.querySelector('#mesh-download-json').href)).json());
    assert.deepEqual(withoutTiming(shown), withoutTiming(result));
    assert.ok(Math.abs(result.mesh.scale_applied - 0.04 / 30) < 1e-9, `scale ${result.mesh.scale_applied}`);
    assert.equal(Number(await page.getAttribute('#mesh-canvas', 'data-scale')), result.mesh.scale_applied);
    checkGeometryFitsFile(text, result);
    // Six faces, each as likely; every grasp at least 40 mm wide, no robust quality asked for.
    assert.deepEqual((await tableCells(page, '#mesh-pose-table')).map((row) => row.slice(1, 3)),
      Array(6).fill(['16.7', '20.0']));
    const grasps = await tableCells(page, '#mesh-grasp-table');
    assert.deepEqual(grasps, expectedGraspCells(result, 0));
    for (const row of grasps) {
      assert.ok(Number(row[1]) >= 39.9 && Number(row[1]) <= 45, `width ${row[1]} mm`);
      assert.equal(row[2], '–');
    }
    assert.match(await page.textContent('#mesh-grid'), /^grid 1 cm$/);
    const view = await viewPixels(page);
    assert.ok(view.differing > view.total * 0.05 && view.magenta > 20, JSON.stringify(view));
    await page.locator('#mesh-canvas').screenshot({ path: artifactPath('mesh-cube-view.png') });
    // On a phone the results fit (the tables scroll inside their boxes): nothing scrolls sideways.
    await page.setViewportSize({ width: 390, height: 844 });
    const widths = await page.evaluate(() => [document.documentElement.scrollWidth,
      document.documentElement.clientWidth]);
    assert.ok(widths[0] <= widths[1], `no sideways scrolling: ${widths}`);
    await page.locator('#mesh').screenshot({ path: artifactPath('mesh-phone.png') });
    assert.deepEqual(errors, []);
    await context.close();
  });

  it('shows the API error message for a file that is not a mesh', async () => {
    const bad = path.join(folder, 'notes.obj');
    await writeFile(bad, 'these are notes, not a mesh\n');
    const api = await askApi(bad, 'format=json&unit=m');
    assert.ok(api.status >= 400 && api.status < 500, `status ${api.status}`);
    const { error } = api.body;

    const { context, page, errors } = await openPage();
    await page.setInputFiles('#mesh-file', bad);
    await page.click('#mesh-submit');
    await page.waitForSelector('#mesh[data-state="error"]');
    assert.equal(await page.textContent('#mesh-error'),
      error.field ? `${error.message} (field: ${error.field})` : error.message);
    assert.equal(await page.isVisible('#mesh-results'), false);
    await page.locator('#mesh').screenshot({ path: artifactPath('mesh-error.png') });
    const unexpected = errors.filter((e) => !/Failed to load resource: .* status of 4\d\d/.test(e));
    assert.deepEqual(unexpected, []);
    await context.close();
  });
});
