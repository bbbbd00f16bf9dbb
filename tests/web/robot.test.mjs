// The robot panel in a real browser (Debian's chromium, headless) against the real
// softgrasp-server with its robot endpoints on, and the SIMULATED robot (softgrasp-sim robot) on
// loopback-only DDS: plan grasps on the robot's own camera image, forward the best one from the
// page, follow it to a final state and compare what the page shows with what the API reports.
// Run by CTest as web_robot_test (tests/web/CMakeLists.txt); screenshots in the artefact folder.
import assert from 'node:assert/strict';
import { randomBytes } from 'node:crypto';
import { mkdtempSync, rmSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { after, before, describe, it } from 'node:test';

import {
  artifactPath, checkPrerequisites, launchBrowser, loopbackDdsConfig, startServer, startSimRobot,
  watchConsole,
} from './harness.mjs';

const STEP_TIMEOUT_MS = 30_000;
const DOMAIN = 131; // this test's own DDS domain; the discovery tag separates parallel runs too
const ROBOT_ID = 'sim-web';
// Scene seed 1 on a table: the planner's best grasp crushes a soft object (docs/sim-robot.md), so
// the page has a failure with a reason, contact widths and damage to show.
const SCENE_SEED = 1;
const FINAL = ['succeeded', 'failed', 'rejected', 'timed_out'];

const token = `web-test-${randomBytes(12).toString('hex')}`;
const tag = `web-robot-${process.pid}-${randomBytes(4).toString('hex')}`;
let workDir;
let robot;
let server;
let robotUrl;
let base;
let browser;

before(async () => {
  checkPrerequisites({ sim: true, data: false });
  workDir = mkdtempSync(path.join(os.tmpdir(), 'softgrasp-web-robot-'));
  const ddsConfig = loopbackDdsConfig(tag);
  // Both at once: the robot's scene build and the server's start-up overlap.
  robot = startSimRobot({ seed: SCENE_SEED, robotId: ROBOT_ID, domain: DOMAIN, ddsConfig });
  server = startServer({
    env: {
      SOFTGRASP_ROBOT_ENABLED: '1',
      SOFTGRASP_ROBOT_TOKENS: token,
      SOFTGRASP_ROBOT_DOMAIN_ID: String(DOMAIN),
      SOFTGRASP_ROBOT_DDS_CONFIG: ddsConfig,
      SOFTGRASP_ROBOT_JOURNAL_DIR: path.join(workDir, 'journal'),
      SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S: '20',
    },
  });
  [robotUrl, base] = await Promise.all([robot.ready, server.ready]);
  browser = await launchBrowser();
});

after(async () => {
  if (browser) await browser.close();
  await Promise.all([server && server.stop(), robot && robot.stop()]);
  if (workDir) rmSync(workDir, { recursive: true, force: true });
});

/** GET /v1/robot until the robot is listed alive (DDS discovery takes a moment). */
async function waitForRobot(timeoutMs = 15_000) {
  const deadline = Date.now() + timeoutMs;
  let list;
  while (Date.now() < deadline) {
    list = await (await fetch(`${base}/v1/robot`)).json();
    if ((list.robots || []).some((r) => r.robot_id === ROBOT_ID && r.alive)) return list;
    await new Promise((resolve) => { setTimeout(resolve, 100); });
  }
  throw new Error(`the service does not hear ${ROBOT_ID}: ${JSON.stringify(list)}\n${server.log()}\n${robot.log()}`);
}

async function robotFile(name) {
  const answer = await fetch(`${robotUrl}/${name}`);
  assert.equal(answer.status, 200, `${robotUrl}/${name}`);
  return Buffer.from(await answer.arrayBuffer());
}

/** The page's result list as {field: text}. */
function shownResult(page) {
  return page.evaluate(() => Object.fromEntries(
    [...document.querySelectorAll('#robot-result dd')].map((dd) => [dd.dataset.field, dd.textContent])));
}

describe('robot panel in chromium with a SIMULATED robot', () => {
  it('forwards the selected grasp and shows the command until its result', async () => {
    const list = await waitForRobot();
    assert.equal(list.robots.find((r) => r.robot_id === ROBOT_ID).simulated, true);
    const depth = await robotFile('depth.npy');
    const intrinsics = await robotFile('camera.intr');

    const context = await browser.newContext({ viewport: { width: 1280, height: 900 } });
    const page = await context.newPage();
    page.setDefaultTimeout(STEP_TIMEOUT_MS);
    const errors = watchConsole(page);
    await page.goto(`${base}/`);
    await page.waitForSelector('body[data-ready="true"]');
    assert.equal(await page.isVisible('#robot'), true);
    assert.equal(await page.isVisible('#robot-nav'), true);
    // The robot list: id, SIMULATED, alive.
    const row = page.locator(`#robot-list tbody tr[data-robot-id="${ROBOT_ID}"]`);
    await row.waitFor();
    assert.deepEqual((await row.locator('td').allTextContents()).slice(0, 4),
      [ROBOT_ID, 'SIMULATED', 'idle', 'yes']);
    assert.match(await row.locator('td').nth(4).textContent(), /^\d+\.\d s ago$/);

    // Plan on the robot's own camera image.
    await page.setInputFiles('#depth-file', { name: 'depth.npy', mimeType: 'application/x-npy', buffer: depth });
    await page.setInputFiles('#intrinsics-file', { name: 'camera.intr', mimeType: 'application/json', buffer: intrinsics });
    await page.click('#grasp-submit');
    await page.waitForSelector('#grasps[data-state="done"]');
    const planned = await page.evaluate(async () =>
      (await fetch(document.querySelector('#download-json').href)).json());
    assert.ok(planned.grasps.length > 0, 'the planner finds a grasp in the robot\'s scene');
    const best = planned.grasps[0];
    await page.check('#grasp-table tbody tr:first-child input[type="radio"]');
    assert.match(await page.textContent('#robot-selection'), /^Selected: grasp 1 of depth\.npy, score /);

    // No token: the page asks for one. A wrong token: the API's 403 message, nothing forwarded.
    await page.click('#robot-forward');
    assert.equal(await page.textContent('#robot-error'), 'Enter the robot token first (robot.tokens of the service).');
    const wrong = 'not-the-token-0123456789';
    const refused = await fetch(`${base}/v1/robot/grasps`, {
      method: 'POST',
      headers: { Authorization: `Bearer ${wrong}`, 'Content-Type': 'application/json' },
      body: JSON.stringify({ ...best, id: 'web-test-wrong-token' }),
    });
    assert.equal(refused.status, 403);
    const { error } = await refused.json();
    await page.fill('#robot-token', wrong);
    await page.click('#robot-forward');
    await page.waitForSelector('#robot[data-state="error"]');
    assert.equal(await page.textContent('#robot-error'), `Token refused: ${error.message} (field: ${error.field})`);
    assert.equal(await page.isVisible('#robot-results'), false);

    // The right token: forwarded, followed to a final state.
    await page.fill('#robot-token', token);
    await page.press('#robot-forward', 'Enter'); // keyboard: the button is focusable and submits
    await page.waitForSelector(FINAL.map((s) => `#robot[data-state="${s}"]`).join(', '));
    assert.equal(await page.isVisible('#robot-error'), false);
    const id = /Command (web-[0-9a-f]{32}) for grasp 1/.exec(await page.textContent('#robot-command'));
    assert.ok(id, await page.textContent('#robot-command'));

    // The page shows what the API reports for the same id.
    const answer = await fetch(`${base}/v1/robot/grasps/${id[1]}`, { headers: { Authorization: `Bearer ${token}` } });
    assert.equal(answer.status, 200);
    const command = await answer.json();
    console.log(`robot: ${JSON.stringify({ state: command.state, result: command.result })}`);
    assert.ok(['succeeded', 'failed'].includes(command.state), `the robot ran the grasp: ${command.state}`);
    assert.equal(command.robot_id, ROBOT_ID);
    assert.deepEqual(command.command.position_m, best.pose.position_m);
    assert.equal(command.command.opening_m, best.opening_m);
    assert.equal(await page.getAttribute('#robot-state', 'data-state'), command.state);
    assert.match(await page.textContent('#robot-state'), new RegExp(`^State: ${command.state}`));
    const steps = await page.$$eval('#robot-steps li', (items) => items.map((li) => [li.dataset.state, li.className]));
    assert.deepEqual(steps.at(-1), [command.state, `current final ${command.state}`]);
    assert.ok(steps.some(([state, cls]) => state === 'sent' && cls === 'done'), JSON.stringify(steps));

    const r = command.result;
    assert.ok(r.reason.length > 0, 'a result says why');
    assert.ok(r.contact_width_m > 0 && r.grasped_width_m > 0 && r.grasped_width_m <= r.contact_width_m);
    const shown = await shownResult(page);
    assert.deepEqual(shown, {
      outcome: r.outcome,
      reason: r.reason,
      robot: ROBOT_ID,
      contact_width: `${(r.contact_width_m * 1000).toFixed(2)} mm`,
      grasped_width: `${(r.grasped_width_m * 1000).toFixed(2)} mm`,
      deformation_rate: `${(r.deformation_rate * 100).toFixed(1)} %`,
      damaged: r.deformation_rate > 0.2 ? 'yes' : 'no',
      execution: `${(r.execution_s * 1000).toFixed(0)} ms`,
      round_trip: `${(r.round_trip_s * 1000).toFixed(0)} ms`,
    });
    // The list is refreshed after the command: the robot is idle again.
    await page.locator(`#robot-list tbody tr[data-robot-id="${ROBOT_ID}"] td:nth-child(3)`)
      .filter({ hasText: 'idle' }).waitFor();
    await page.screenshot({ path: artifactPath('robot.png'), fullPage: true });

    // The robot leaves the bus: the next forward is refused with the API's 503 and its Retry-After.
    await robot.stop();
    let gone;
    const goneBy = Date.now() + 10_000;
    do {
      gone = await fetch(`${base}/v1/robot/grasps`, {
        method: 'POST',
        headers: { Authorization: `Bearer ${token}`, 'Content-Type': 'application/json' },
        body: JSON.stringify({ ...best, id: `web-test-gone-${Date.now()}` }),
      });
    } while (gone.status !== 503 && Date.now() < goneBy);
    assert.equal(gone.status, 503);
    const retryAfter = gone.headers.get('retry-after');
    const unavailable = (await gone.json()).error;
    await page.click('#robot-forward');
    await page.waitForSelector('#robot[data-state="error"]');
    const field = unavailable.field ? ` (field: ${unavailable.field})` : '';
    assert.equal(await page.textContent('#robot-error'),
      `No robot can take it now: ${unavailable.message}${field} (try again in ${retryAfter} s)`);
    await page.click('#robot-refresh');
    await page.locator(`#robot-list tbody tr[data-robot-id="${ROBOT_ID}"] td:nth-child(4)`)
      .filter({ hasText: 'no' }).waitFor();

    // Phone-sized: the panel with its result scrolls nowhere sideways.
    await page.setViewportSize({ width: 390, height: 844 });
    const widths = await page.evaluate(() => [document.documentElement.scrollWidth, document.documentElement.clientWidth]);
    assert.ok(widths[0] <= widths[1], `no sideways scrolling: ${widths}`);
    await page.locator('#robot').screenshot({ path: artifactPath('robot-phone.png') });

    // The only console lines allowed: the browser's own notes on the refused requests (403, 503).
    const unexpected = errors.filter((e) => !/Failed to load resource: .* status of (403|503)/.test(e));
    assert.deepEqual(unexpected, []);
    await context.close();
  });
});
