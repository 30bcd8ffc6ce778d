// What the browser tests share: their arguments, a log of checks, a short simulated approach,
// `cdff serve` started on a free port, and Debian's Chromium driven by Playwright (headless).
import { spawn, spawnSync } from 'node:child_process';
import { existsSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

/// CDFF (the `cdff` program) and OUT_DIR (emptied) from the command line.
export function testArguments(script) {
  const [cdff, out] = process.argv.slice(2);
  if (!cdff || !out) {
    console.error(`usage: node ${script} CDFF OUT_DIR`);
    process.exit(2);
  }
  rmSync(out, { recursive: true, force: true });
  mkdirSync(out, { recursive: true });
  return { cdff, out };
}

let failures = 0;
export function check(name, ok, detail = '') {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${name}${detail ? `: ${detail}` : ''}`);
  if (!ok) failures += 1;
}
export function finish() {
  process.exit(failures ? 1 : 0);
}

/// Two seconds of the mid-range approach with 320x240 cameras, written to `recording`.
export function simulate(cdff, recording) {
  const small = [];
  for (const camera of ['camera_left', 'camera_right']) {
    small.push('--set', `sensors.${camera}.width=320`, '--set', `sensors.${camera}.height=240`,
               '--set', `sensors.${camera}.fx=300`, '--set', `sensors.${camera}.fy=300`);
  }
  const sim = spawnSync(cdff, ['sim', 'mid_range_approach', '-o', recording, '--duration', '2',
                               '--seed', '1', '-q', ...small], { encoding: 'utf8' });
  if (sim.status !== 0) {
    console.error(`FAIL: cdff sim exited with ${sim.status}: ${sim.stderr}`);
    process.exit(1);
  }
}

/// dfpcs/pose_filtering.yaml fed with the simulator's /truth/target_pose (a graph that runs on what
/// `cdff sim` records, in the truth's frame so that the plots compare like with like), written
/// into `out`; its path.
export function truthFilteringGraph(root, out) {
  const graph = path.join(out, 'truth_filtering.yaml');
  writeFileSync(graph, readFileSync(path.join(root, 'dfpcs/pose_filtering.yaml'), 'utf8')
    .replaceAll('/chaser/target_pose_measurement', '/truth/target_pose'));
  return graph;
}

/// `cdff run GRAPH -i INPUT -o OUTPUT`, the truth and every /chaser/ channel passed through (the
/// recording of a run, with its products, for the Replay page's estimate).
export function runGraph(cdff, graph, input, output) {
  const run = spawnSync(cdff, ['run', graph, '-i', input, '-o', output, '-q',
                               '--passthrough', '/truth/', '--passthrough', '/chaser/'], { encoding: 'utf8' });
  if (run.status !== 0) {
    console.error(`FAIL: cdff run exited with ${run.status}: ${run.stderr}`);
    process.exit(1);
  }
}

/// What the 3D view's canvas shows, read back from its WebGL drawing buffer: its size, the pixels
/// that are not the background, and those of the scan (yellow), the estimated model (light blue,
/// shaded) and the truth's wireframe (green).
export function scenePixels(page, id) {
  return page.evaluate((canvasId) => {
    const source = document.getElementById(canvasId);
    const copy = document.createElement('canvas');
    copy.width = source.width;
    copy.height = source.height;
    const ctx = copy.getContext('2d');
    ctx.drawImage(source, 0, 0);
    const d = ctx.getImageData(0, 0, copy.width, copy.height).data;
    const count = { width: copy.width, height: copy.height, lit: 0, points: 0, model: 0, truth: 0 };
    for (let i = 0; i < d.length; i += 4) {
      const [r, g, b] = [d[i], d[i + 1], d[i + 2]];
      if (Math.abs(r - 0x10) + Math.abs(g - 0x15) + Math.abs(b - 0x1d) > 24) count.lit += 1;
      if (r > 200 && g > 150 && b < 140) count.points += 1;
      if (b > 120 && g > 80 && r > 30 && b > r + 40) count.model += 1;
      if (g > 150 && r < 110 && b > 60 && b < 170 && g > b + 40) count.truth += 1;
    }
    return count;
  }, id);
}

/// The contour overlay of an image: its segments and the pixels it has drawn (not transparent).
export function overlayPixels(page, id) {
  return page.evaluate((canvasId) => {
    const canvas = document.getElementById(canvasId);
    const d = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    let drawn = 0;
    for (let i = 3; i < d.length; i += 4) if (d[i] > 0) drawn += 1;
    return { segments: Number(canvas.dataset.segments ?? 0), drawn, width: canvas.width, height: canvas.height };
  }, id);
}

/// `cdff serve ARGS --port 0`: the process and the address it printed.
export function startServer(cdff, args, options = {}) {
  return new Promise((resolve, reject) => {
    const server = spawn(cdff, ['serve', ...args, '--port', '0'],
                         { ...options, stdio: ['ignore', 'pipe', 'inherit'] });
    let text = '';
    const timer = setTimeout(() => reject(new Error(`cdff serve printed no address: ${text}`)), 30000);
    server.stdout.on('data', (chunk) => {
      text += chunk;
      const m = text.match(/listening on (http:\/\/\S+)/);
      if (m) {
        clearTimeout(timer);
        resolve({ server, url: m[1] });
      }
    });
    server.on('exit', (code) => reject(new Error(`cdff serve exited with ${code}: ${text}`)));
  });
}

/// Chromium (CDFF_CHROMIUM, or Debian's /usr/bin/chromium), headless, through playwright-core
/// from the build tree's node_modules (NODE_PATH, set by CTest: ES modules do not search it).
export async function launchChromium() {
  if (!process.env.NODE_PATH) {
    console.error('FAIL: NODE_PATH must name the build\'s web/node_modules (CTest sets it)');
    process.exit(2);
  }
  const require = createRequire(path.join(path.resolve(process.env.NODE_PATH), 'noop.js'));
  const { chromium } = require('playwright-core');
  const browserPath = process.env.CDFF_CHROMIUM ?? '/usr/bin/chromium';
  if (!existsSync(browserPath)) {
    console.error(`FAIL: no Chromium at ${browserPath}. This test drives Debian's Chromium; install `
      + "it with 'sudo bash scripts/install-deps.sh' (package chromium), or set CDFF_CHROMIUM.");
    process.exit(1);
  }
  return chromium.launch({
    executablePath: browserPath,
    headless: true,
    // Chromium's sandbox cannot run as root (CI's user); containers often have a small /dev/shm.
    // WebGL (the 3D view) without a GPU: ANGLE on SwiftShader, the CPU renderer Chromium ships,
    // which it no longer falls back to unless told it may.
    args: ['--disable-dev-shm-usage', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           ...(process.getuid?.() === 0 ? ['--no-sandbox'] : [])],
  });
}

/** A page of `browser` that records its console errors and uncaught exceptions in `errors`. */
export async function openPage(browser, viewport, errors) {
  const page = await browser.newPage({ viewport });
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(e.message));
  return page;
}

/**
 * The end of a browser test: closes Chromium, stops `cdff serve` (SIGTERM), checks that the page
 * logged no error and that the server exited 0, and gives the verdict.
 */
export async function closeAndFinish(browser, server, errors) {
  await browser.close();
  server.kill('SIGTERM');
  check('no-console-error', errors.length === 0, errors.join(' | '));
  const code = server.exitCode ?? await new Promise((resolve) => server.on('exit', resolve));
  check('serve-stops-on-sigterm', code === 0, `exit ${code}`);
  finish();
}
