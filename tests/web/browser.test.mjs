// The page in a real browser (Debian's chromium, headless) against the real softgrasp-server:
// upload a Primesense frame and see its grasps listed and drawn, over the depth and over the
// stiffness map of the shipped model, generate a fractal and see it rendered, see the API's own
// message for a bad upload, and no console errors anywhere. A second server without a stiffness
// model shows that the page then offers no stiffness view and still finds grasps.
// Screenshots go to <build>/tests/web/artifacts/. Run by CTest (tests/web/CMakeLists.txt).
import assert from 'node:assert/strict';
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { after, before, describe, it } from 'node:test';

import {
  artifactPath, checkPrerequisites, launchBrowser, paths, readCanvas, startServer,
  watchConsole,
} from './harness.mjs';

const FRAME = path.join(paths.data, 'gqcnn', 'primesense', 'single_depth_0.npy');
const INTRINSICS = path.join(paths.data, 'gqcnn', 'primesense', 'primesense.intr');
const STEP_TIMEOUT_MS = 30_000;
const GREEN = [0, 255, 0, 255]; // the best grasp, as the service's overlay draws it
const MAGENTA = [255, 0, 255, 255]; // the grasp selected in the table
// single_depth_0: the long object in the middle of the frame, which the shipped pix2stiffness
// model maps as hard (about 0.99), away from where the grasps are drawn (its upper end), and
// points of the floor/bin that it maps as background (0). Image pixels (u, v).
const HARD_BAR = [[340, 282], [352, 255], [330, 288], [345, 270]];
const BACKGROUND = [[100, 100], [500, 150], [20, 300], [600, 250]];
const MEAN_STIFFNESS_COLUMN = 5; // Show, Rank, Score, Width, Height, Mean stiffness, ...

let server;
let base;
let browser;

before(async () => {
  checkPrerequisites();
  server = startServer();
  base = await server.ready;
  browser = await launchBrowser();
});

after(async () => {
  if (browser) await browser.close();
  if (server) await server.stop();
});

/** A fresh page (own context: no cache shared between tests) with its console watched. */
async function openPage(viewport = { width: 1280, height: 900 }, at = base) {
  const context = await browser.newContext({ viewport, acceptDownloads: true });
  const page = await context.newPage();
  page.setDefaultTimeout(STEP_TIMEOUT_MS);
  const errors = watchConsole(page);
  await page.goto(`${at}/`);
  await page.waitForSelector('body[data-ready="true"]');
  return { context, page, errors };
}

/** Where the two fingers of a grasp are centred, in image pixels (service/io/overlay.cpp). */
function fingerCentres(grasp) {
  const axis = [Math.cos(grasp.angle_rad), Math.sin(grasp.angle_rad)];
  const offset = grasp.opening_px / 2 + grasp.finger_thickness_px / 2;
  const { u, v } = grasp.center_px;
  return [-1, 1].map((s) => [u + s * axis[0] * offset, v + s * axis[1] * offset]);
}

/** RGBA of canvas pixels at image points (the canvas holds the picture at 1:1). */
function canvasPixels(page, selector, points) {
  return page.evaluate(([sel, pts]) => {
    const ctx = document.querySelector(sel).getContext('2d');
    return pts.map(([x, y]) => Array.from(ctx.getImageData(Math.round(x), Math.round(y), 1, 1).data));
  }, [selector, points]);
}

/** RGBA at image points of the PNG a download link points at. */
function linkedPngPixels(page, selector, points) {
  return page.evaluate(async ([sel, pts]) => {
    const blob = await (await fetch(document.querySelector(sel).href)).blob();
    const bitmap = await createImageBitmap(blob);
    const canvas = new OffscreenCanvas(bitmap.width, bitmap.height);
    const ctx = canvas.getContext('2d');
    ctx.drawImage(bitmap, 0, 0);
    return pts.map(([x, y]) => Array.from(ctx.getImageData(Math.round(x), Math.round(y), 1, 1).data));
  }, [selector, points]);
}

/** Keeps a copy of the canvas pixels in the page; `canvasChange` compares with it. */
function snapshotCanvas(page, selector) {
  return page.evaluate((sel) => {
    const canvas = document.querySelector(sel);
    window.testSnapshot = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
  }, selector);
}

/** How many pixels of the canvas differ (in RGB) from the last snapshot, of how many. */
function canvasChange(page, selector) {
  return page.evaluate((sel) => {
    const canvas = document.querySelector(sel);
    const { data } = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height);
    const old = window.testSnapshot;
    let differing = 0;
    for (let i = 0; i < data.length; i += 4) {
      if (data[i] !== old[i] || data[i + 1] !== old[i + 1] || data[i + 2] !== old[i + 2]) differing += 1;
    }
    return { differing, total: data.length / 4 };
  }, selector);
}

/** A little-endian float32 C-order NPY (what /v1/stiffness format=npy answers) as rows. */
function readNpyFloat32(bytes) {
  assert.equal(bytes.subarray(0, 6).toString('latin1'), '\x93NUMPY');
  const headerLength = bytes.readUInt16LE(8);
  const header = bytes.subarray(10, 10 + headerLength).toString('latin1');
  assert.match(header, /'descr': '<f4'/);
  assert.match(header, /'fortran_order': False/);
  const [height, width] = /'shape': \((\d+), (\d+)\)/.exec(header).slice(1).map(Number);
  const data = new Float32Array(bytes.buffer.slice(bytes.byteOffset + 10 + headerLength,
    bytes.byteOffset + 10 + headerLength + 4 * width * height));
  return { width, height, at: (u, v) => data[v * width + u] };
}

/** The frame and its intrinsics as the page sends them, for requests made from node. */
async function frameForm(fields = {}) {
  const form = new FormData();
  form.append('depth', new Blob([await readFile(FRAME)]), path.basename(FRAME));
  form.append('intrinsics', new Blob([await readFile(INTRINSICS)]), path.basename(INTRINSICS));
  for (const [name, value] of Object.entries(fields)) form.append(name, value);
  return form;
}

/** Uploads the frame and its .intr with the file pickers and waits for the results. */
async function findGrasps(page) {
  await page.setInputFiles('#depth-file', FRAME);
  await page.setInputFiles('#intrinsics-file', INTRINSICS);
  await page.click('#grasp-submit');
  await page.waitForSelector('#grasps[data-state="done"]');
  return page.evaluate(async () => (await fetch(document.querySelector('#download-json').href)).json());
}

/** Pixels of the 3D preview that differ from its background (the corner pixel). */
async function previewCoverage(page) {
  const { width, height, data } = await readCanvas(page, '#fractal-canvas');
  const bg = [data[0], data[1], data[2]];
  let differing = 0;
  for (let i = 0; i < data.length; i += 4) {
    const d = Math.abs(data[i] - bg[0]) + Math.abs(data[i + 1] - bg[1]) + Math.abs(data[i + 2] - bg[2]);
    if (d > 24) differing += 1;
  }
  return { differing, total: width * height, background: bg };
}

/** Drops a file on an element as a person dragging it from the desktop would. */
async function dropFile(page, selector, filePath) {
  const bytes = (await readFile(filePath)).toString('base64');
  const transfer = await page.evaluateHandle(([b64, name]) => {
    const raw = atob(b64);
    const data = new Uint8Array(raw.length);
    for (let i = 0; i < raw.length; i += 1) data[i] = raw.charCodeAt(i);
    const dt = new DataTransfer();
    dt.items.add(new File([data], name, { type: 'application/octet-stream' }));
    return dt;
  }, [bytes, path.basename(filePath)]);
  await page.dispatchEvent(selector, 'dragover', { dataTransfer: transfer });
  await page.dispatchEvent(selector, 'drop', { dataTransfer: transfer });
}

describe('softgrasp page in chromium', () => {
  it('serves the page and its bundles with their caching headers', async () => {
    const page = await fetch(`${base}/`);
    assert.equal(page.status, 200);
    assert.match(page.headers.get('content-type'), /^text\/html/);
    assert.equal(page.headers.get('cache-control'), 'no-cache');
    const etag = page.headers.get('etag');
    assert.ok(etag);
    const html = await page.text();
    const script = /src="(\/assets\/app-[A-Z0-9]{8}\.js)"/.exec(html);
    assert.ok(script, 'index.html names a hashed bundle');
    const bundle = await fetch(`${base}${script[1]}`);
    assert.equal(bundle.status, 200);
    assert.match(bundle.headers.get('content-type'), /^text\/javascript/);
    assert.equal(bundle.headers.get('cache-control'), 'public, max-age=31536000, immutable');
    const again = await fetch(`${base}/`, { headers: { 'If-None-Match': etag } });
    assert.equal(again.status, 304);
  });

  it('finds grasps in a dropped depth image with its .intr and draws them', async () => {
    const { context, page, errors } = await openPage();
    await dropFile(page, '#depth-drop', FRAME);
    await page.locator('#depth-file-name').filter({ hasText: 'single_depth_0.npy' }).waitFor();
    await page.setInputFiles('#intrinsics-file', INTRINSICS);
    await page.click('#grasp-submit');
    await page.waitForSelector('#grasps[data-state="done"]');

    const result = await page.evaluate(async () =>
      (await fetch(document.querySelector('#download-json').href)).json());
    assert.equal(result.camera.source, 'request');
    assert.ok(result.grasps.length > 0, 'the service found grasps');
    const rows = page.locator('#grasp-table tbody tr');
    assert.equal(await rows.count(), result.grasps.length);
    assert.equal(await rows.first().locator('td').nth(2).textContent(), result.grasps[0].score.toFixed(3));
    assert.match(await page.textContent('#grasp-summary'), /640×480 npy/);

    // The best grasp's fingers are green where the JSON puts them, in the page's picture and in
    // the service's overlay, and turning the grasps off shows the depth there instead.
    const best = fingerCentres(result.grasps[0]);
    const drawn = await canvasPixels(page, '#grasp-canvas', best);
    assert.deepEqual(drawn, [GREEN, GREEN]);
    assert.deepEqual(await linkedPngPixels(page, '#download-overlay', best), [GREEN, GREEN]);
    await page.screenshot({ path: artifactPath('grasps.png'), fullPage: true });
    await page.click('#show-grasps');
    const plain = await canvasPixels(page, '#grasp-canvas', best);
    for (let i = 0; i < best.length; i += 1) assert.notDeepEqual(plain[i], drawn[i]);
    assert.deepEqual(await linkedPngPixels(page, '#download-depth', best), plain);
    await page.click('#show-grasps');

    // Keyboard: arrow keys move the highlight to the next grasp, drawn in magenta.
    if (result.grasps.length > 1) {
      await page.focus('#grasp-table tbody input[type="radio"]');
      await page.keyboard.press('ArrowDown');
      const second = fingerCentres(result.grasps[1]);
      assert.deepEqual(await canvasPixels(page, '#grasp-canvas', second), [MAGENTA, MAGENTA]);
      assert.equal(await page.locator('#grasp-table tbody tr.selected').getAttribute('data-rank'), '2');
    }
    assert.deepEqual(errors, []);
    await context.close();
  });

  it('shows the stiffness map of the shipped model under the grasps, and mean stiffness', async () => {
    const info = await (await fetch(`${base}/v1/info`)).json();
    // (A segmentation model may be listed too, once one ships: the objects panel's business.)
    assert.deepEqual(info.models.filter((m) => m.kind === 'stiffness').map((m) => [m.name, m.kind]),
      [['pix2stiffness', 'stiffness']]);
    assert.deepEqual(info.strategies, ['fge', 'gqcnn', 'stiffness', 'deformability']);
    assert.equal(info.default_strategy, 'deformability');
    // What the model says about the frame, straight from the API: the bar is hard, the floor is
    // background. The page must show exactly that.
    const map = readNpyFloat32(Buffer.from(await (await fetch(`${base}/v1/stiffness`,
      { method: 'POST', body: await frameForm({ format: 'npy' }) })).arrayBuffer()));
    assert.deepEqual([map.width, map.height], [640, 480]);
    for (const [u, v] of HARD_BAR) assert.ok(map.at(u, v) >= 0.9, `hard at ${u},${v}: ${map.at(u, v)}`);
    for (const [u, v] of BACKGROUND) assert.equal(map.at(u, v), 0, `background at ${u},${v}`);

    const { context, page, errors } = await openPage();
    const requests = [];
    page.on('request', (request) => requests.push(new URL(request.url()).pathname));
    const strategy = await page.$eval('#strategy', (select) => ({
      options: [...select.options].map((o) => o.value), value: select.value,
    }));
    // With the segmentation model shipped too, deformability is preselected; pick stiffness.
    assert.deepEqual(strategy,
      { options: ['fge', 'gqcnn', 'stiffness', 'deformability'], value: 'deformability' });
    await page.selectOption('#strategy', 'stiffness');
    assert.equal(await page.isVisible('#strategy-field-target_policy'), false);
    assert.equal(await page.isVisible('#picture-choice'), false, 'no view switch before results');

    const result = await findGrasps(page);
    assert.equal(requests.filter((p) => p === '/v1/stiffness').length, 1, 'one map per press');
    assert.equal(result.strategy, 'stiffness');
    assert.equal(result.stiffness_model, 'pix2stiffness');
    assert.ok(result.grasps.length > 0);
    const cells = await page.locator(`#grasp-table tbody tr td:nth-child(${MEAN_STIFFNESS_COLUMN + 1})`)
      .allTextContents();
    assert.deepEqual(cells, result.grasps.map((g) => g.mean_stiffness.toFixed(2)));
    for (const g of result.grasps) assert.ok(g.mean_stiffness >= 0 && g.mean_stiffness <= 1, `${g.mean_stiffness}`);
    assert.match(await page.textContent('#grasp-summary'), /strategy stiffness \(model pix2stiffness\)/);
    assert.equal(await page.getAttribute('#grasp-canvas', 'data-picture'), 'depth');
    assert.equal(await page.isVisible('#stiffness-legend'), false);
    assert.equal(await page.isVisible('#download-stiffness'), true);
    assert.equal(await page.isVisible('#picture-deformability-label'), false);
    assert.equal(await page.getAttribute('#download-stiffness', 'download'), 'single_depth_0-stiffness.png');

    // Keyboard: the view switch is a radio group; the right arrow moves from Depth to Stiffness.
    // The pictures are compared without the grasps (their antialiased edges may be rasterised
    // differently once the canvas has been read back).
    await page.click('#show-grasps');
    await snapshotCanvas(page, '#grasp-canvas');
    await page.focus('#picture-depth');
    await page.keyboard.press('ArrowRight');
    assert.equal(await page.isChecked('#picture-stiffness'), true);
    assert.equal(await page.getAttribute('#grasp-canvas', 'data-picture'), 'stiffness');
    const change = await canvasChange(page, '#grasp-canvas');
    assert.ok(change.differing > change.total * 0.5, `${change.differing} of ${change.total} px changed`);
    assert.equal(await page.isVisible('#stiffness-legend'), true);
    assert.match(await page.getAttribute('#grasp-canvas', 'aria-label'), /^Stiffness map/);

    // The map shows: warm (red over blue) on the hard bar, black on the background, the same
    // pixels as the service's PNG there, and the best grasp still green on top.
    const hard = await canvasPixels(page, '#grasp-canvas', HARD_BAR);
    for (const [r, g, b] of hard) assert.ok(r >= 100 && r > 2 * b && r > 2 * g, `warm: ${[r, g, b]}`);
    const floor = await canvasPixels(page, '#grasp-canvas', BACKGROUND);
    for (const [r, g, b] of floor) assert.ok(r + g + b <= 24, `black-ish: ${[r, g, b]}`);
    assert.deepEqual(await linkedPngPixels(page, '#download-stiffness', [...HARD_BAR, ...BACKGROUND]),
      [...hard, ...floor]);
    await page.click('#show-grasps');
    const best = fingerCentres(result.grasps[0]);
    assert.deepEqual(await canvasPixels(page, '#grasp-canvas', best), [GREEN, GREEN]);
    await page.screenshot({ path: artifactPath('stiffness.png'), fullPage: true });

    // And back: the depth picture again, exactly as before.
    await page.click('#show-grasps');
    await page.focus('#picture-stiffness');
    await page.keyboard.press('ArrowLeft');
    assert.equal(await page.getAttribute('#grasp-canvas', 'data-picture'), 'depth');
    assert.equal((await canvasChange(page, '#grasp-canvas')).differing, 0);

    // On a phone the switch and the legend fit: nothing scrolls sideways.
    await page.check('#picture-stiffness');
    await page.setViewportSize({ width: 390, height: 844 });
    const widths = await page.evaluate(() => [document.documentElement.scrollWidth,
      document.documentElement.clientWidth]);
    assert.ok(widths[0] <= widths[1], `no sideways scrolling: ${widths}`);
    assert.equal(await page.isVisible('#stiffness-legend'), true);
    await page.screenshot({ path: artifactPath('stiffness-phone.png'), fullPage: true });
    assert.deepEqual(errors, []);
    await context.close();
  });

  it('grasps one target object with the deformability strategy over its deformability map', async () => {
    const info = await (await fetch(`${base}/v1/info`)).json();
    assert.deepEqual(info.target_policies, ['highest', 'least_deformable']);
    assert.deepEqual(info.overlays, ['depth', 'stiffness', 'deformability']);
    const { context, page, errors } = await openPage();
    assert.equal(await page.inputValue('#strategy'), 'deformability');
    assert.equal(await page.isVisible('#strategy-field-target_policy'), true);
    assert.equal(await page.inputValue('#target_policy'), 'highest');
    await page.selectOption('#target_policy', 'least_deformable');

    const result = await findGrasps(page);
    assert.equal(result.strategy, 'deformability');
    assert.equal(result.target.policy, 'least_deformable');
    assert.ok(Number.isInteger(result.target.id) && result.target.id > 0, JSON.stringify(result.target));
    assert.ok(result.grasps.length > 0);
    for (const g of result.grasps) {
      assert.equal(g.instance_id, result.target.id);
      assert.equal(g.deformability.target_policy, 'least_deformable');
      assert.ok(g.deformability.mean_deformability >= 0 && g.deformability.mean_deformability <= 1);
    }
    assert.match(await page.textContent('#grasp-summary'),
      new RegExp(`target object ${result.target.id} \\(least deformable\\)`));

    // The deformability picture: the map with the target outlined, the legend's ends say what
    // the colours mean, the best grasp still green on top.
    assert.equal(await page.isVisible('#picture-deformability-label'), true);
    await page.check('#picture-deformability');
    assert.equal(await page.getAttribute('#grasp-canvas', 'data-picture'), 'deformability');
    assert.equal(await page.isVisible('#stiffness-legend'), true);
    assert.equal(await page.textContent('#legend-high'), 'rigid 0.0');
    assert.match(await page.getAttribute('#grasp-canvas', 'aria-label'), /^Deformability map/);
    assert.deepEqual(await canvasPixels(page, '#grasp-canvas', fingerCentres(result.grasps[0])),
      [GREEN, GREEN]);
    assert.equal(await page.isVisible('#download-deformability'), true);
    await page.screenshot({ path: artifactPath('deformability.png'), fullPage: true });
    // Back to the stiffness picture: its legend's ends again.
    await page.check('#picture-stiffness');
    assert.equal(await page.textContent('#legend-high'), 'hard 1.0');

    await page.selectOption('#strategy', 'fge');
    assert.equal(await page.isVisible('#strategy-field-target_policy'), false);
    assert.deepEqual(errors, []);
    await context.close();
  });

  it('shows the API error message for an invalid upload', async () => {
    const bytes = Buffer.from('this is not a depth image');
    const direct = new FormData();
    direct.append('depth', new Blob([bytes]), 'broken.npy');
    const answer = await fetch(`${base}/v1/grasps`, { method: 'POST', body: direct });
    assert.ok(answer.status >= 400 && answer.status < 500);
    const { error } = await answer.json();

    const { context, page, errors } = await openPage();
    await page.setInputFiles('#depth-file', { name: 'broken.npy', mimeType: 'application/octet-stream', buffer: bytes });
    await page.click('#grasp-submit');
    await page.waitForSelector('#grasps[data-state="error"]');
    const shown = await page.textContent('#grasp-error');
    assert.equal(shown, error.field ? `${error.message} (field: ${error.field})` : error.message);
    assert.equal(await page.isVisible('#grasp-results'), false);
    await page.screenshot({ path: artifactPath('grasps-error.png') });
    // The browser reports the refused requests themselves; anything else is a fault of the page.
    const unexpected = errors.filter((e) => !/Failed to load resource: .* status of 4\d\d/.test(e));
    assert.deepEqual(unexpected, []);
    await context.close();
  });

  it('generates a fractal, previews it in 3D and shows its statistics', async () => {
    const { context, page, errors } = await openPage();
    await page.fill('#fractal-seed', '42');
    await page.fill('#fractal-points', '4000');
    await page.selectOption('#fractal-format', 'stl_binary');
    await page.click('#fractal-submit');
    await page.waitForSelector('#fractals[data-state="done"]');

    const stats = await page.evaluate(async () =>
      (await fetch(document.querySelector('#download-stats').href)).json());
    assert.equal(stats.seed, 42);
    assert.equal(stats.points, 4000);
    const listed = await page.textContent('#fractal-stats');
    assert.ok(listed.includes(`Vertices${stats.vertices}`), listed);
    assert.ok(listed.includes(`Faces${stats.faces}`), listed);
    assert.equal(await page.getAttribute('#download-mesh', 'download'), 'fractal-seed42-alpha0.3.stl');
    const meshBytes = await page.evaluate(async () =>
      (await (await fetch(document.querySelector('#download-mesh').href)).arrayBuffer()).byteLength);
    assert.equal(meshBytes, 84 + 50 * stats.faces); // binary STL: header, count, 50 B a face
    assert.equal(await page.isVisible('#fractal-preview-note'), false);

    const shown = await previewCoverage(page);
    assert.ok(shown.differing > shown.total * 0.01, `mesh covers ${shown.differing} px`);
    assert.ok(shown.differing < shown.total * 0.9, 'and not the whole view');
    await page.screenshot({ path: artifactPath('fractal.png'), fullPage: true });

    // Interactive: zooming in with the keyboard makes the mesh cover more of the view.
    await page.focus('#fractal-canvas');
    for (let i = 0; i < 3; i += 1) await page.keyboard.press('+');
    const zoomed = await previewCoverage(page);
    assert.ok(zoomed.differing > shown.differing * 1.3, `${zoomed.differing} vs ${shown.differing}`);
    assert.deepEqual(errors, []);
    await context.close();
  });

  it('says why the robot panel is off when the service has no robot tokens', async () => {
    const info = await (await fetch(`${base}/v1/info`)).json();
    assert.equal(info.robot.enabled, false); // this server runs without SOFTGRASP_ROBOT_TOKENS
    const { context, page, errors } = await openPage();
    assert.equal(await page.isVisible('#robot'), true);
    assert.equal(await page.textContent('#robot-disabled'), `The robot endpoints are off: ${info.robot.reason}.`);
    assert.equal(await page.isVisible('#robot-token'), false);
    assert.equal(await page.isVisible('#robot-forward'), false);
    assert.deepEqual(errors, []);
    await context.close();
  });

  it('is usable on a phone-sized screen, every control labelled', async () => {
    const { context, page, errors } = await openPage({ width: 390, height: 844 });
    const layout = await page.evaluate(() => ({
      scrollWidth: document.documentElement.scrollWidth,
      clientWidth: document.documentElement.clientWidth,
      unlabelled: [...document.querySelectorAll('input, select, button, canvas[tabindex]')]
        .filter((el) => !(el.labels && el.labels.length) && !el.getAttribute('aria-label')
          && !(el.tagName === 'BUTTON' && el.textContent.trim()))
        .map((el) => el.id || el.outerHTML.slice(0, 60)),
    }));
    assert.ok(layout.scrollWidth <= layout.clientWidth, `no sideways scrolling: ${JSON.stringify(layout)}`);
    assert.deepEqual(layout.unlabelled, []);
    // The first Tab lands on the skip link, which jumps past the header to the panels.
    await page.keyboard.press('Tab');
    assert.equal(await page.evaluate(() => document.activeElement.className), 'skip-link');
    await page.screenshot({ path: artifactPath('phone.png'), fullPage: true });
    assert.deepEqual(errors, []);
    await context.close();
  });
});

describe('softgrasp page in chromium, server without models', () => {
  let plainServer;
  let plainBase;

  before(async () => {
    plainServer = startServer({ stiffnessModel: 'none', segmentationModel: 'none', gqcnnModel: 'none' });
    plainBase = await plainServer.ready;
  });

  after(async () => {
    if (plainServer) await plainServer.stop();
  });

  it('offers only FGE, shows no stiffness view and still finds grasps', async () => {
    const info = await (await fetch(`${plainBase}/v1/info`)).json();
    assert.deepEqual(info.models.filter((m) => m.kind === 'stiffness'), []);
    assert.deepEqual(info.strategies, ['fge']);
    assert.equal(info.default_strategy, 'fge');

    const { context, page, errors } = await openPage({ width: 1280, height: 900 }, plainBase);
    const requests = [];
    page.on('request', (request) => requests.push(new URL(request.url()).pathname));
    const strategy = await page.$eval('#strategy', (select) => ({
      options: [...select.options].map((o) => o.value), value: select.value,
    }));
    assert.deepEqual(strategy, { options: ['fge'], value: 'fge' });

    const result = await findGrasps(page);
    assert.equal(result.strategy, 'fge');
    assert.equal(result.stiffness_model, null);
    assert.ok(result.grasps.length > 0, 'the service found grasps');
    assert.equal(await page.locator('#grasp-table tbody tr').count(), result.grasps.length);
    const cells = await page.locator(`#grasp-table tbody tr td:nth-child(${MEAN_STIFFNESS_COLUMN + 1})`)
      .allTextContents();
    assert.deepEqual(cells, result.grasps.map(() => '–'));
    for (const g of result.grasps) assert.equal(g.mean_stiffness, null);
    assert.deepEqual(await canvasPixels(page, '#grasp-canvas', fingerCentres(result.grasps[0])),
      [GREEN, GREEN]);
    for (const hidden of ['#picture-choice', '#stiffness-legend', '#download-stiffness',
      '#download-deformability', '#strategy-field-target_policy']) {
      assert.equal(await page.isVisible(hidden), false, hidden);
    }
    assert.equal(await page.getAttribute('#grasp-canvas', 'data-picture'), 'depth');
    assert.deepEqual(requests.filter((p) => p.startsWith('/v1/stiffness')), []);
    await page.screenshot({ path: artifactPath('grasps-no-model.png'), fullPage: true });
    assert.deepEqual(errors, []);
    await context.close();
  });
});
