// Shared by the browser tests: where things are, the real server on a free port, and Debian's
// chromium driven headless by playwright-core (from web/node_modules, installed by `npm ci`).
import { spawn } from 'node:child_process';
import { existsSync, mkdirSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));

/** Paths, from the environment CTest sets (tests/web/CMakeLists.txt), else the default layout. */
export const paths = (() => {
  const source = process.env.SOFTGRASP_SOURCE_DIR || path.resolve(here, '..', '..');
  const build = process.env.SOFTGRASP_BUILD_DIR || path.join(source, 'build');
  return {
    source,
    server: process.env.SOFTGRASP_SERVER || path.join(build, 'service', 'softgrasp-server'),
    sim: process.env.SOFTGRASP_SIM || path.join(build, 'sim', 'softgrasp-sim'),
    webRoot: process.env.SOFTGRASP_WEB_ROOT || path.join(build, 'web'),
    artifacts: process.env.SOFTGRASP_ARTIFACT_DIR || path.join(build, 'tests', 'web', 'artifacts'),
    // Real camera frames kept with the tests (tests/data/README.md).
    data: path.join(source, 'tests', 'data'),
    chromium: process.env.SOFTGRASP_CHROMIUM || '/usr/bin/chromium',
  };
})();

export function artifactPath(name) {
  mkdirSync(paths.artifacts, { recursive: true });
  return path.join(paths.artifacts, name);
}

/** Fails early with what to do when something the tests need is missing. */
export function checkPrerequisites({ sim = false, data = true } = {}) {
  const missing = [];
  if (sim && !existsSync(paths.sim)) missing.push(`simulated robot ${paths.sim} (run scripts/build.sh)`);
  if (!existsSync(paths.server)) missing.push(`server ${paths.server} (run scripts/build.sh)`);
  if (!existsSync(path.join(paths.webRoot, 'index.html'))) {
    missing.push(`built page ${paths.webRoot}/index.html (run scripts/build.sh)`);
  }
  if (!existsSync(paths.chromium)) missing.push(`${paths.chromium} (run scripts/setup.sh)`);
  if (data && !existsSync(paths.data)) missing.push(`data folder ${paths.data} (part of the repository)`);
  if (missing.length) throw new Error(`browser tests need: ${missing.join('; ')}`);
}

/** playwright-core as the web package installed it. */
export function playwright() {
  const require = createRequire(path.join(paths.source, 'web', 'package.json'));
  return require('playwright-core');
}

/**
 * Starts a program that prints "listening on http://HOST:PORT" on stdout once it serves.
 * `ready` resolves with that URL; `stop` sends SIGTERM (graceful), SIGKILL after 10 s.
 */
function startListening(exe, args, { env = {}, what, timeoutMs = 20_000 } = {}) {
  const child = spawn(exe, args, { stdio: ['ignore', 'pipe', 'pipe'], env: { ...process.env, ...env } });
  let log = '';
  child.stderr.on('data', (chunk) => { log = (log + chunk).slice(-20_000); });
  const ready = new Promise((resolve, reject) => {
    const timer = setTimeout(() => {
      child.kill('SIGKILL');
      reject(new Error(`${what} did not start within ${timeoutMs} ms:\n${log}`));
    }, timeoutMs);
    let out = '';
    child.stdout.on('data', (chunk) => {
      out = (out + chunk).slice(-20_000);
      const match = /listening on (http:\/\/\S+)/.exec(out);
      if (match) {
        clearTimeout(timer);
        resolve(match[1]);
      }
    });
    child.on('exit', (code, signal) => {
      clearTimeout(timer);
      reject(new Error(`${what} exited (${code ?? signal}) before listening:\n${log}`));
    });
  });
  ready.catch(() => {}); // callers await it; a late rejection must not be "unhandled"
  const stop = () => new Promise((resolve) => {
    if (child.exitCode !== null || child.signalCode !== null) return resolve();
    const timer = setTimeout(() => child.kill('SIGKILL'), 10_000);
    child.once('exit', () => {
      clearTimeout(timer);
      resolve();
    });
    child.kill('SIGTERM'); // graceful: in-flight requests finish
  });
  return { ready, stop, log: () => log, pid: child.pid };
}

/**
 * Starts softgrasp-server on 127.0.0.1, port 0, serving the built page. Resolves with its base
 * URL once it prints "listening on http://HOST:PORT". `env` adds settings (SOFTGRASP_ROBOT_...).
 * `stiffnessModel`: a model file, or 'none' to serve without one; unset, the server loads the
 * shipped model next to its executable (<build>/models/pix2stiffness.pt). `segmentationModel`
 * likewise (<build>/models/segmentation.pt when it exists, else the PCL baseline), and
 * `gqcnnModel` (<build>/models/gqcnn.pt when it exists, else strategy=gqcnn is not served).
 */
export function startServer({
  timeoutMs = 20_000, env = {}, stiffnessModel, segmentationModel, gqcnnModel,
} = {}) {
  const args = ['--host', '127.0.0.1', '--port', '0', '--workers', '2', '--web-root', paths.webRoot];
  if (stiffnessModel !== undefined) args.push('--stiffness-model', String(stiffnessModel));
  if (segmentationModel !== undefined) {
    args.push('--segmentation-model', String(segmentationModel));
  }
  if (gqcnnModel !== undefined) args.push('--gqcnn-model', String(gqcnnModel));
  return startListening(paths.server, args, { env, what: 'softgrasp-server', timeoutMs });
}

/**
 * Cyclone DDS on loopback only: the 127.0.0.1 interface, no multicast, unicast discovery to this
 * host, and a discovery tag so that parallel runs on the same domain do not see each other
 * (scripts/run.sh, tests/netns/two_hosts_test.sh --loopback).
 */
export function loopbackDdsConfig(tag) {
  return '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/>'
    + '</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>'
    + `<Tag>${tag}</Tag><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>`
    + '<Peers><Peer address="127.0.0.1"/></Peers><LeaseDuration>2 s</LeaseDuration></Discovery>'
    + '</Domain></CycloneDDS>';
}

/**
 * Starts the SIMULATED robot (softgrasp-sim robot, docs/sim-robot.md) with its scene views on
 * 127.0.0.1 at a free port. Resolves with the views' base URL. Building the scene (a Bullet drop)
 * takes a few seconds.
 */
export function startSimRobot({ seed, robotId, domain, ddsConfig, timeoutMs = 45_000 }) {
  return startListening(paths.sim,
    ['robot', '--scene-seed', String(seed), '--support', 'table', '--robot-id', robotId,
      '--domain', String(domain), '--dds-config', ddsConfig, '--http-host', '127.0.0.1',
      '--http-port', '0'],
    { what: 'softgrasp-sim robot', timeoutMs });
}

/** Debian's chromium, headless, with nothing talking to the network on its own. */
export async function launchBrowser() {
  const { chromium } = playwright();
  return chromium.launch({
    executablePath: paths.chromium,
    headless: true,
    timeout: 30_000,
    args: [
      '--no-sandbox',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-default-apps',
      '--disable-sync',
      '--disable-extensions',
      '--disable-dev-shm-usage',
      '--no-first-run',
      '--no-default-browser-check',
      '--metrics-recording-only',
      '--mute-audio',
      // WebGL without a GPU: SwiftShader, asked for explicitly (CI machines have no GPU).
      '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader',
    ],
  });
}

/**
 * The RGBA pixels a canvas shows (drawn onto a fresh 2-D canvas, so WebGL canvases read too):
 * { width, height, data } with data a plain array of width * height * 4 bytes.
 */
export function readCanvas(page, selector) {
  return page.evaluate((sel) => {
    const source = document.querySelector(sel);
    const canvas = document.createElement('canvas');
    canvas.width = source.width;
    canvas.height = source.height;
    const ctx = canvas.getContext('2d');
    ctx.drawImage(source, 0, 0);
    const { data } = ctx.getImageData(0, 0, canvas.width, canvas.height);
    return { width: canvas.width, height: canvas.height, data: Array.from(data) };
  }, selector);
}

/** Records console errors and uncaught exceptions of a page. */
export function watchConsole(page) {
  const errors = [];
  page.on('console', (message) => {
    if (message.type() === 'error') errors.push(`console: ${message.text()}`);
  });
  page.on('pageerror', (error) => errors.push(`pageerror: ${error.message}`));
  return errors;
}
