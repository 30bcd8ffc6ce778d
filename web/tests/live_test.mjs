// The Live page in a real browser (Playwright driving Debian's Chromium, headless), against
// `cdff serve` on a recording that `cdff sim` writes first. A live run started from the page
// (dfpcs/pose_filtering.yaml fed with the recording's /truth/target_pose, given with --graph)
// produces poses on the plot beside the truth, the camera image and the DFPC's row; the row's
// Stop and Init (stopDFPC, initDFPC), Idle, Resume and Stop move the states; no console error.
// Screenshots go to OUT_DIR.
// usage: node live_test.mjs CDFF OUT_DIR   (NODE_PATH: the build's web/node_modules)
import { spawn, spawnSync } from 'node:child_process';
import { existsSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const [cdff, out] = process.argv.slice(2);
if (!cdff || !out) {
  console.error('usage: node live_test.mjs CDFF OUT_DIR');
  process.exit(2);
}
// playwright-core is in the build tree's node_modules (NODE_PATH, set by CTest), not beside this
// file; ES modules do not search NODE_PATH, so it is required from there.
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

let failures = 0;
function check(name, ok, detail = '') {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${name}${detail ? `: ${detail}` : ''}`);
  if (!ok) failures += 1;
}

rmSync(out, { recursive: true, force: true });
mkdirSync(out, { recursive: true });

// A short approach with small cameras: two seconds of frames and truth poses.
const recording = path.join(out, 'live.mcap');
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

// The pose filter of dfpcs/pose_filtering.yaml fed with the simulator's truth (a graph that
// runs on what `cdff sim` records, in the truth's frame so that the plot compares like with like).
const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const graph = path.join(out, 'truth_filtering.yaml');
writeFileSync(graph, readFileSync(path.join(root, 'dfpcs/pose_filtering.yaml'), 'utf8')
  .replaceAll('/chaser/target_pose_measurement', '/truth/target_pose'));

function startServer() {
  return new Promise((resolve, reject) => {
    // From the repository's root: its dfpcs/ are offered too.
    const server = spawn(cdff, ['serve', recording, '--port', '0', '--graph', graph],
                         { cwd: root, stdio: ['ignore', 'pipe', 'inherit'] });
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

const { server, url } = await startServer();
const browser = await chromium.launch({
  executablePath: browserPath,
  headless: true,
  // Chromium's sandbox cannot run as root (CI's user); containers often have a small /dev/shm.
  args: ['--disable-dev-shm-usage', ...(process.getuid?.() === 0 ? ['--no-sandbox'] : [])],
});
const consoleErrors = [];
const waitFor = (page, fn, arg, timeout = 30000) =>
  page.waitForFunction(fn, arg, { timeout }).then(() => true, () => false);
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(e.message));
  await page.goto(`${url}#live`);
  await page.waitForSelector('#live[data-ready="true"]', { timeout: 30000 });
  const graphs = await page.$$eval('#live-graph option', (os) => os.map((o) => o.value));
  check('graph-list', graphs.includes(graph) && graphs.includes('dfpcs/pose_filtering.yaml'),
        graphs.join(', '));
  await page.selectOption('#live-graph', graph);
  await page.selectOption('#live-recording', '0');
  await page.selectOption('#live-speed', '1');
  await page.click('#live-start');
  check('running', await waitFor(page, () => document.body.dataset.liveState === 'running'),
        await page.$eval('#live-state', (p) => p.textContent));

  // Poses on the plot, beside every truth pose of the recording; the camera image; the DFPC.
  const info = await page.evaluate(() => fetch('/api/recordings/0').then((r) => r.json()));
  const truth = info.channels.find((c) => c.topic === '/truth/target_pose');
  check('poses-on-plot', await waitFor(page, () => Number(document.getElementById('live-plot').dataset.estimates) >= 10),
        `${await page.$eval('#live-plot', (p) => p.dataset.estimates)} estimates`);
  const truthPoints = Number(await page.$eval('#live-plot', (p) => p.dataset.truth));
  check('truth-on-plot', truthPoints === truth?.messages, `${truthPoints} truth points of ${truth?.messages}`);
  check('camera-image', await waitFor(page, () => document.getElementById('live-frame').dataset.t !== undefined),
        await page.$eval('#live-frame-caption', (c) => c.textContent));
  check('dfpc-row', await waitFor(page, () => document.querySelector('#live-dfpcs tr[data-name="pose_filtering"]')?.dataset.state === 'running'),
        await page.$eval('#live-dfpcs tbody', (b) => b.textContent));
  check('events-log', await page.$$eval('#live-events li', (lis) => lis.length) > 0, 'lifecycle events listed');
  const pose = await page.$eval('#live-pose', (p) => p.textContent);
  check('pose-text', /pose_filtering: target in \S+ at \d/.test(pose), pose);
  // The whole recording played: the plot holds the run from start to end.
  check('recording-consumed', await waitFor(page, () => /consumed/.test(document.getElementById('live-state').textContent)),
        await page.$eval('#live-state', (p) => p.textContent));
  await page.screenshot({ path: path.join(out, 'live-running.png') });

  // One DFPC stopped and initialised again (stopDFPC, initDFPC) from its row.
  await page.click('#live-dfpcs tr[data-name="pose_filtering"] button[data-request="stop"]');
  check('dfpc-stopped', await waitFor(page, () => document.querySelector('#live-dfpcs tr[data-name="pose_filtering"]').dataset.state === 'stopped'),
        await page.$eval('#live-dfpcs tbody', (b) => b.textContent));
  await page.click('#live-dfpcs tr[data-name="pose_filtering"] button[data-request="init"]');
  check('dfpc-initialised', await waitFor(page, () => document.querySelector('#live-dfpcs tr[data-name="pose_filtering"]').dataset.state === 'running'),
        await page.$eval('#live-dfpcs tbody', (b) => b.textContent));

  await page.click('#live-idle');
  check('idle', await waitFor(page, () => document.body.dataset.liveState === 'idle'),
        await page.$eval('#live-state', (p) => p.textContent));
  await page.click('#live-resume');
  check('resumed', await waitFor(page, () => document.body.dataset.liveState === 'running'),
        await page.$eval('#live-state', (p) => p.textContent));
  await page.click('#live-stop');
  check('stopped', await waitFor(page, () => document.body.dataset.liveState === 'none'
                                 && /stopped/.test(document.getElementById('live-state').textContent)),
        await page.$eval('#live-state', (p) => p.textContent));
  check('start-again-enabled', !(await page.$eval('#live-start', (b) => b.disabled)), 'Start is enabled');
  await page.screenshot({ path: path.join(out, 'live-stopped.png') });
} catch (e) {
  check('browser', false, e.message);
} finally {
  await browser.close();
  server.kill('SIGTERM');
}
check('no-console-error', consoleErrors.length === 0, consoleErrors.join(' | '));
const code = server.exitCode ?? await new Promise((resolve) => server.on('exit', resolve));
check('serve-stops-on-sigterm', code === 0, `exit ${code}`);
process.exit(failures ? 1 : 0);
