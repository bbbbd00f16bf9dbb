// The page in a real browser (Debian's chromium, headless) against the real softgrasp-server:
// upload a Primesense frame and see its grasps listed and drawn, generate a fractal and see it
// rendered, see the API's own message for a bad upload, and no console errors anywhere.
// Screenshots go to <build>/tests/web/artifacts/. Run by CTest (tests/web/CMakeLists.txt).
import assert from 'node:assert/strict';
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { after, before, describe, it } from 'node:test';

import {
  artifactPath, checkPrerequisites, launchBrowser, paths, startServer, watchConsole,
} from './harness.mjs';

const FRAME = path.join(paths.data, 'gqcnn', 'primesense', 'single_depth_0.npy');
const INTRINSICS = path.join(paths.data, 'gqcnn', 'primesense', 'primesense.intr');
const STEP_TIMEOUT_MS = 30_000;
const GREEN = [0, 255, 0, 255]; // the best grasp, as the service's overlay draws it
const MAGENTA = [255, 0, 255, 255]; // the grasp selected in the table

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
async function openPage(viewport = { width: 1280, height: 900 }) {
  const context = await browser.newContext({ viewport, acceptDownloads: true });
  const page = await context.newPage();
  page.setDefaultTimeout(STEP_TIMEOUT_MS);
  const errors = watchConsole(page);
  await page.goto(`${base}/`);
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

/** Pixels of the 3D preview that differ from its background (the corner pixel). */
function previewCoverage(page) {
  return page.evaluate(() => {
    const source = document.querySelector('#fractal-canvas');
    const canvas = document.createElement('canvas');
    canvas.width = source.width;
    canvas.height = source.height;
    const ctx = canvas.getContext('2d');
    ctx.drawImage(source, 0, 0);
    const { data } = ctx.getImageData(0, 0, canvas.width, canvas.height);
    const bg = [data[0], data[1], data[2]];
    let differing = 0;
    for (let i = 0; i < data.length; i += 4) {
      const d = Math.abs(data[i] - bg[0]) + Math.abs(data[i + 1] - bg[1]) + Math.abs(data[i + 2] - bg[2]);
      if (d > 24) differing += 1;
    }
    return { differing, total: canvas.width * canvas.height, background: bg };
  });
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
