// The objects panel in a real browser (Debian's chromium, headless) against the real
// softgrasp-server with the PCL baseline: segment the Primesense frame chosen in the grasps panel,
// see the service's overlay and the instance table, click an object on the picture and in the
// table to make it the grasp target, and find grasps on that object only. Screenshots go to
// <build>/tests/web/artifacts/. Run by CTest (tests/web/CMakeLists.txt).
import assert from 'node:assert/strict';
import path from 'node:path';
import { after, before, describe, it } from 'node:test';

import { decodeLabelsPng, instanceAt } from '../../web/src/segmentation_model.js';
import {
  artifactPath, checkPrerequisites, launchBrowser, paths, startServer, watchConsole,
} from './harness.mjs';

const FRAME = path.join(paths.data, 'gqcnn', 'primesense', 'single_depth_0.npy');
const INTRINSICS = path.join(paths.data, 'gqcnn', 'primesense', 'primesense.intr');
const STEP_TIMEOUT_MS = 30_000;
const OBJECT_COLUMN = 9; // Show, Rank, Score, Width, Height, Stiffness, Angle, Position, Orientation, Object

let server;
let base;
let browser;

before(async () => {
  checkPrerequisites();
  server = startServer({ segmentationModel: 'none', stiffnessModel: 'none' });
  base = await server.ready;
  browser = await launchBrowser();
});

after(async () => {
  if (browser) await browser.close();
  if (server) await server.stop();
});

/** A pixel of instance `id`: the one nearest its centroid (the centroid may lie outside it). */
function pixelOf(labels, id, [cu, cv]) {
  let best = null;
  let bestDistance = Infinity;
  for (let v = 0; v < labels.height; v += 1) {
    for (let u = 0; u < labels.width; u += 1) {
      if (labels.ids[v * labels.width + u] !== id) continue;
      const d = (u - cu) ** 2 + (v - cv) ** 2;
      if (d < bestDistance) {
        bestDistance = d;
        best = [u, v];
      }
    }
  }
  return best;
}

describe('objects panel in chromium', () => {
  it('segments the depth image, shows the objects and targets grasps at a clicked one', async () => {
    const info = await (await fetch(`${base}/v1/info`)).json();
    assert.deepEqual(info.segmentation_methods, ['pcl']);

    const context = await browser.newContext({ viewport: { width: 1280, height: 900 }, acceptDownloads: true });
    const page = await context.newPage();
    page.setDefaultTimeout(STEP_TIMEOUT_MS);
    const errors = watchConsole(page);
    await page.goto(`${base}/`);
    await page.waitForSelector('body[data-ready="true"]');
    assert.deepEqual(await page.$eval('#segmentation-method', (s) => [...s.options].map((o) => o.value)),
      ['pcl']);

    // Without a depth image the panel says where to choose one.
    await page.click('#segmentation-submit');
    assert.match(await page.textContent('#segmentation-error'), /Choose a depth image/);

    await page.setInputFiles('#depth-file', FRAME);
    await page.setInputFiles('#intrinsics-file', INTRINSICS);
    await page.click('#segmentation-submit');
    await page.waitForSelector('#segmentation[data-state="done"]');
    const result = await page.evaluate(async () =>
      (await fetch(document.querySelector('#download-instances').href)).json());
    assert.equal(result.method, 'pcl');
    assert.ok(result.instances.length >= 1, 'the service found objects');
    const rows = page.locator('#instance-table tbody tr');
    assert.equal(await rows.count(), result.instances.length);
    assert.deepEqual(await rows.locator('td:nth-child(2)').allTextContents(),
      result.instances.map((i) => String(i.id)));
    assert.deepEqual(await rows.locator('td:nth-child(6)').allTextContents(),
      result.instances.map(() => '–')); // PCL estimates no deformability
    assert.deepEqual(await page.$eval('#segmentation-canvas', (c) => [c.width, c.height]), [640, 480]);
    assert.equal(await page.getAttribute('#segmentation', 'data-target'), '0');

    // The labels the page holds are the service's: click the first object on the picture.
    const labelBytes = await page.evaluate(async () => Array.from(new Uint8Array(await (await fetch(
      document.querySelector('#download-labels').href)).arrayBuffer())));
    const labels = await decodeLabelsPng(Uint8Array.from(labelBytes));
    const first = result.instances[0];
    const [u, v] = pixelOf(labels, first.id, first.centroid_px);
    assert.equal(instanceAt(labels, u, v), first.id);
    const box = await page.locator('#segmentation-canvas').boundingBox();
    await page.mouse.click(box.x + ((u + 0.5) * box.width) / 640, box.y + ((v + 0.5) * box.height) / 480);
    assert.equal(await page.getAttribute('#segmentation', 'data-target'), String(first.id));
    assert.equal(await page.getAttribute('#instance-table tbody tr.selected', 'data-id'), String(first.id));
    // The picked object is outlined in white on the picture.
    const outlined = await page.evaluate(() => {
      const canvas = document.querySelector('#segmentation-canvas');
      const { data } = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height);
      let white = 0;
      for (let i = 0; i < data.length; i += 4) {
        if (data[i] === 255 && data[i + 1] === 255 && data[i + 2] === 255) white += 1;
      }
      return white;
    });
    assert.ok(outlined > 50, `${outlined} outline pixels`);

    assert.match(await page.textContent('#grasp-target'), new RegExp(`Only object ${first.id}\\b`));
    await page.screenshot({ path: artifactPath('objects.png'), fullPage: true });

    // The grasps panel now asks for grasps on that object only.
    await page.click('#grasp-submit');
    await page.waitForSelector('#grasps[data-state="done"]');
    const grasps = await page.evaluate(async () =>
      (await fetch(document.querySelector('#download-json').href)).json());
    assert.equal(grasps.contact_region.target, first.id);
    assert.equal(grasps.segmentation.source, 'labels');
    for (const g of grasps.grasps) assert.equal(g.instance_id, first.id);
    const objects = await page.locator(`#grasp-table tbody tr td:nth-child(${OBJECT_COLUMN + 1})`)
      .allTextContents();
    assert.deepEqual(objects, grasps.grasps.map(() => String(first.id)));
    await page.screenshot({ path: artifactPath('objects-target-grasps.png'), fullPage: true });

    // A row click picks another object; "Any object" clears the target.
    if (result.instances.length > 1) {
      await rows.nth(1).locator('td').nth(1).click();
      assert.equal(await page.getAttribute('#segmentation', 'data-target'),
        String(result.instances[1].id));
    }
    await page.click('#segmentation-clear-target');
    assert.equal(await page.getAttribute('#segmentation', 'data-target'), '0');
    assert.equal(await page.isVisible('#grasp-target'), false);

    // Without a target the grasps still name their objects, from the same labels (no second
    // segmentation), on any object.
    await page.evaluate(() => { document.querySelector('#grasps').dataset.state = 'again'; });
    await page.click('#grasp-submit');
    await page.waitForSelector('#grasps[data-state="done"]');
    const anyObject = await page.evaluate(async () =>
      (await fetch(document.querySelector('#download-json').href)).json());
    assert.equal(anyObject.contact_region.target, null);
    assert.equal(anyObject.segmentation.source, 'labels');
    for (const g of anyObject.grasps) assert.ok(Number.isInteger(g.instance_id), JSON.stringify(g));
    assert.deepEqual(errors, []);
    await context.close();
  });
});
