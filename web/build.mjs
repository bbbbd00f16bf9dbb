// Bundles the page into the folder softgrasp-server serves (its web root):
//   OUT/index.html        no-cache + ETag (names the current bundles)
//   OUT/assets/*-HASH.*   content-hashed: cached for a year as immutable
// Usage: node web/build.mjs --outdir build/web   (scripts/build.sh runs it after `npm ci`)
import { mkdir, readFile, readdir, rename, rm, writeFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import * as esbuild from 'esbuild';

const here = path.dirname(fileURLToPath(import.meta.url));

function outDirFromArgs(argv) {
  const i = argv.indexOf('--outdir');
  if (i < 0 || !argv[i + 1]) {
    throw new Error('usage: node web/build.mjs --outdir DIR');
  }
  return path.resolve(argv[i + 1]);
}

// Every file under assets/ must carry a content hash, or the immutable caching would be wrong.
const HASHED = /-[A-Z0-9]{8}\.(js|css|map|js\.map|css\.map)$/;

async function build(outDir) {
  const staging = `${outDir}.staging`;
  await rm(staging, { recursive: true, force: true });
  const result = await esbuild.build({
    absWorkingDir: here,
    entryPoints: { app: 'src/main.js' },
    bundle: true,
    splitting: true, // three.js loads only when the first mesh is shown
    format: 'esm',
    target: ['es2020', 'chrome100', 'firefox100', 'safari15'],
    minify: true,
    sourcemap: 'linked',
    outdir: path.join(staging, 'assets'),
    entryNames: '[name]-[hash]',
    chunkNames: 'chunk-[hash]',
    assetNames: '[name]-[hash]',
    metafile: true,
    logLevel: 'warning',
  });
  const outputs = Object.entries(result.metafile.outputs);
  const entry = outputs.find(([, o]) => o.entryPoint === 'src/main.js');
  if (!entry) throw new Error('esbuild produced no entry bundle');
  const js = path.basename(entry[0]);
  const css = entry[1].cssBundle ? path.basename(entry[1].cssBundle) : null;
  if (!css) throw new Error('esbuild produced no stylesheet');

  for (const name of await readdir(path.join(staging, 'assets'))) {
    if (!HASHED.test(name)) throw new Error(`asset without a content hash: ${name}`);
  }
  const template = await readFile(path.join(here, 'index.html'), 'utf8');
  const html = template.replace('%APP_JS%', js).replace('%APP_CSS%', css);
  if (html.includes('%APP_')) throw new Error('index.html has an unknown placeholder');
  await writeFile(path.join(staging, 'index.html'), html);

  // Swap the folders so that a running server never serves a half-written page.
  await mkdir(path.dirname(outDir), { recursive: true });
  const old = `${outDir}.old`;
  await rm(old, { recursive: true, force: true });
  await rename(outDir, old).catch((error) => {
    if (error.code !== 'ENOENT') throw error;
  });
  await rename(staging, outDir);
  await rm(old, { recursive: true, force: true });

  const sizes = outputs
    .filter(([file]) => !file.endsWith('.map'))
    .map(([file, o]) => `${path.basename(file)} ${(o.bytes / 1024).toFixed(0)} KiB`);
  console.log(`web: ${path.relative(process.cwd(), outDir) || outDir}: index.html, ${sizes.join(', ')}`);
}

build(outDirFromArgs(process.argv)).catch((error) => {
  console.error(`web build failed: ${error.message}`);
  process.exit(1);
});
