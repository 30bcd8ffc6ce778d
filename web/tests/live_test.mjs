// The Live page in a real browser (Playwright driving Debian's Chromium, headless), against
// `cdff serve` on a recording that `cdff sim` writes first. A live run started from the page
// (dfpcs/pose_filtering.yaml fed with the recording's /truth/target_pose, given with --graph)
// produces poses on the plot beside the truth, the camera image and the DFPC's row; the row's
// Stop and Init (stopDFPC, initDFPC), Idle, Resume and Stop move the states; no console error.
// Screenshots go to OUT_DIR.
// usage: node live_test.mjs CDFF OUT_DIR   (NODE_PATH: the build's web/node_modules)
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import {
  check, closeAndFinish, launchChromium, openPage, overlayPixels, scenePixels, simulate,
  startServer, testArguments, truthFilteringGraph,
} from './harness.mjs';

const { cdff, out } = testArguments('live_test.mjs');
const recording = path.join(out, 'live.mcap');
simulate(cdff, recording);

// The pose filter of dfpcs/pose_filtering.yaml fed with the simulator's truth.
const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const graph = truthFilteringGraph(root, out);

// From the repository's root: its dfpcs/ are offered too.
const { server, url } = await startServer(cdff, [recording, '--graph', graph], { cwd: root });
const browser = await launchChromium();
const consoleErrors = [];
const waitFor = (page, fn, arg, timeout = 30000) =>
  page.waitForFunction(fn, arg, { timeout }).then(() => true, () => false);
try {
  const page = await openPage(browser, { width: 1280, height: 900 }, consoleErrors);
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
  await page.screenshot({ path: path.join(out, 'live-running.png'), fullPage: true });

  // The 3D view: the latest LIDAR scan (thinned by the server), the model (the recording's
  // /truth/target_mesh: this graph names no mesh_file) at the estimated pose and the truth's
  // wireframe, drawn in WebGL.
  const scene = await page.$eval('#live-scene', (c) => ({ ...c.dataset }));
  check('3d-points', Number(scene.points) > 0 && Number(scene.points) <= 20000
        && (await page.$eval('#live-scene-caption', (c) => c.textContent)).includes(`${scene.points} of `),
        `${scene.points} points; ${await page.$eval('#live-scene-caption', (c) => c.textContent)}`);
  check('3d-trajectories', Number(scene.estimateTrack) >= 10 && Number(scene.truthTrack) === truth?.messages,
        `${scene.estimateTrack} estimated positions, ${scene.truthTrack} true ones of ${truth?.messages}`);
  check('3d-model-at-estimate-and-truth', Number(scene.model) > 0 && scene.estimate === 'true' && scene.truth === 'true',
        JSON.stringify(scene));
  const pixels = await scenePixels(page, 'live-scene');
  check('3d-webgl-pixels', pixels.lit > 1000 && pixels.points > 20
        && pixels.model > 200 && pixels.truth > 50, JSON.stringify(pixels));
  await page.locator('#live-scene').screenshot({ path: path.join(out, 'live-scene.png') });

  // The model's contour at the latest estimate over the camera image (sent with the image).
  const contour = await overlayPixels(page, 'live-frame-overlay');
  check('contour-over-image', contour.segments > 0 && contour.drawn > 50, JSON.stringify(contour));
  await page.locator('#live .frame-box').screenshot({ path: path.join(out, 'live-contour.png') });

  // Errors against time with the thresholds of the requirement at the truth's range (from the
  // server, eval's table): every threshold drawn is one of GET /api/requirements'.
  const table = await page.evaluate(() => fetch('/api/requirements').then((r) => r.json()));
  const plot = await page.$eval('#live-error-plot', (p) => ({ ...p.dataset }));
  const drawn = JSON.parse(plot.thresholds ?? '{}');
  const allowed = (quantity) => table.pose.filter((r) => r.quantity === quantity).map((r) => r.threshold);
  check('error-plot-points', Number(plot.points) >= 10, `${plot.points} errors`);
  check('error-plot-thresholds',
        ['position_error_m', 'angle_error_deg'].every((q) => drawn[q]?.length > 0 && drawn[q].every((v) => allowed(q).includes(v))),
        `${plot.thresholds} (requirements ${plot.requirements})`);
  const legend = await page.$$eval('#live-error-plot .u-legend .u-label', (ls) => ls.map((l) => l.textContent));
  check('error-plot-threshold-lines', legend.some((l) => l.startsWith('position threshold'))
        && legend.some((l) => l.startsWith('attitude threshold')), legend.join(' | '));
  await page.locator('#live-error-plot').screenshot({ path: path.join(out, 'live-errors.png') });

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
}
await closeAndFinish(browser, server, consoleErrors);
