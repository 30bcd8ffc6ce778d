// The Replay page in a real browser (Playwright driving Debian's Chromium, headless), against
// `cdff serve` on a recording that `cdff sim` writes first. Checks: the page loads with no
// console error; scrubbing the timeline shows the frame of that time (its time stamp, and the
// same JPEG as the server's image of that frame); playing advances the frame; the pose plot has
// the channel's points. Screenshots go to OUT_DIR.
// usage: node replay_test.mjs CDFF OUT_DIR   (NODE_PATH: the build's web/node_modules)
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import {
  check, closeAndFinish, launchChromium, openPage, overlayPixels, runGraph, scenePixels, simulate,
  startServer, testArguments, truthFilteringGraph,
} from './harness.mjs';

const { cdff, out } = testArguments('replay_test.mjs');
const recording = path.join(out, 'replay.mcap');
simulate(cdff, recording);
// Recording 1: a run of the truth-fed pose filter on it (its product /cdff/pose_filtering/state,
// the truth and the sensors passed through), for the estimate in 3D and its errors.
const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const run = path.join(out, 'run.mcap');
runGraph(cdff, truthFilteringGraph(root, out), recording, run);

const { server, url } = await startServer(cdff, [recording, run]);
const browser = await launchChromium();
const consoleErrors = [];
try {
  const page = await openPage(browser, { width: 1280, height: 900 }, consoleErrors);
  await page.goto(url);
  await page.waitForSelector('body[data-ready="true"]', { timeout: 30000 });
  await page.waitForSelector('#frame[data-t]', { timeout: 30000 });

  const info = await page.evaluate(() => fetch('/api/recordings/0').then((r) => r.json()));
  const camera = await page.$eval('#image-channel', (s) => s.value);
  const pose = await page.$eval('#pose-channel', (s) => s.value);
  const channel = info.channels.find((c) => c.topic === camera);
  check('camera-channel', camera === '/chaser/camera/left/image' && channel?.rate_hz > 0,
        `${camera} at ${channel?.rate_hz} Hz`);
  const rows = await page.$$eval('#channels tbody tr', (trs) => trs.length);
  check('channel-list', rows === info.channels.length, `${rows} rows for ${info.channels.length} channels`);
  await page.screenshot({ path: path.join(out, 'replay-start.png') });

  // The frame times of the camera, from the recording's own messages.
  const times = await page.evaluate(async ({ camera, n }) => {
    const q = new URLSearchParams({ channel: camera, t: '0', count: String(n) });
    const r = await fetch(`/api/recordings/0/messages?${q}`).then((x) => x.json());
    return r.messages.map((m) => m.t);
  }, { camera, n: channel.messages });
  check('frame-times', times.length === channel.messages, `${times.length} frames`);

  const scrubTo = async (fraction) => {
    const box = await page.locator('#scrub').boundingBox();
    await page.mouse.click(box.x + box.width * fraction, box.y + box.height / 2);
    const t = Number(await page.$eval('#scrub', (s) => s.value));
    await page.waitForFunction((want) => document.body.dataset.position === want,
                               t.toFixed(6), { timeout: 10000 });
    const shown = Number(await page.$eval('#frame', (img) => img.dataset.t));
    const expected = times.filter((f) => f <= t + 1e-9).at(-1) ?? times[0];
    check(`scrub-${fraction}-frame-of-that-time`, Math.abs(shown - expected) < 1e-6,
          `scrubbed to ${t.toFixed(3)} s, shows the frame at ${shown.toFixed(6)} s, expected ${expected.toFixed(6)} s`);
    // The pixels shown are that frame's: those of the server's image at that time, both
    // decoded by the browser (fetching the page's blob: URL would break its CSP).
    const same = await page.evaluate(async ({ camera, t }) => {
      const pixels = (img) => {
        const canvas = document.createElement('canvas');
        canvas.width = img.naturalWidth;
        canvas.height = img.naturalHeight;
        const ctx = canvas.getContext('2d');
        ctx.drawImage(img, 0, 0);
        return ctx.getImageData(0, 0, canvas.width, canvas.height).data;
      };
      const shown = document.getElementById('frame');
      await shown.decode();
      const served = new Image();
      served.src = `/api/recordings/0/image?${new URLSearchParams({ channel: camera, t: String(t), max_width: '640' })}`;
      await served.decode();
      const a = pixels(shown);
      const b = pixels(served);
      return a.length > 0 && a.length === b.length && a.every((v, i) => v === b[i]);
    }, { camera, t: shown });
    check(`scrub-${fraction}-pixels`, same, 'the image shown has the pixels of the server\'s image of that frame');
    return shown;
  };
  const late = await scrubTo(0.8);
  await page.screenshot({ path: path.join(out, 'replay-scrubbed.png') });
  const early = await scrubTo(0.25);
  check('scrub-moves', late > early, `${early} s then ${late} s`);

  const points = Number(await page.$eval('#plot', (p) => p.dataset.points));
  const poseChannel = info.channels.find((c) => c.topic === pose);
  check('pose-plot', pose === '/truth/target_pose' && points === poseChannel.messages,
        `${points} points of ${pose} (${poseChannel?.messages} messages)`);

  // Another camera: the stream is reopened on it, at the start of the recording.
  await page.selectOption('#image-channel', '/chaser/camera/right/image');
  const switched = await page.waitForFunction(
    () => document.getElementById('frame').dataset.channel === '/chaser/camera/right/image',
    null, { timeout: 10000 },
  ).then(() => true, () => false);
  check('camera-switch', switched, await page.$eval('#frame-caption', (c) => c.textContent));

  await page.click('#play');
  const advanced = await page.waitForFunction(
    (t0) => Number(document.getElementById('frame').dataset.t) > t0 + 0.2, 0, { timeout: 10000 },
  ).then(() => true, () => false);
  await page.click('#play');  // pause
  const now = Number(await page.$eval('#frame', (img) => img.dataset.t));
  check('play-advances', advanced, `from 0 s to ${now.toFixed(3)} s`);
  await page.screenshot({ path: path.join(out, 'replay-played.png') });

  // The 3D view of the simulator's recording (no estimate): the LIDAR scan thinned by the server
  // and the model (/truth/target_mesh) as the truth's wireframe, in the LIDAR's frame.
  const sceneOf = () => page.$eval('#scene', (c) => ({ ...c.dataset }));
  await page.waitForFunction(() => document.getElementById('scene').dataset.truth === 'true', null, { timeout: 10000 })
    .catch(() => {});
  let scene = await sceneOf();
  const caption = await page.$eval('#scene-caption', (c) => c.textContent);
  check('3d-points', Number(scene.points) > 0 && Number(scene.points) <= 20000 && caption.includes(`${scene.points} of `),
        `${scene.points} points; ${caption}`);
  check('3d-truth-wireframe', Number(scene.model) > 0 && scene.truth === 'true' && scene.estimate !== 'true', JSON.stringify(scene));
  const truthChannel = info.channels.find((c) => c.topic === '/truth/target_pose');
  check('3d-truth-trajectory', Number(scene.truthTrack) === truthChannel.messages,
        `${scene.truthTrack} positions of ${truthChannel.messages}`);
  let pixels = await scenePixels(page, 'scene');
  check('3d-webgl-pixels', pixels.lit > 1000 && pixels.points > 20 && pixels.truth > 50,
        JSON.stringify(pixels));
  // The model's contour at the truth's pose over the camera image (projected by the server).
  const contoured = await page.waitForFunction(() => Number(document.getElementById('frame-overlay').dataset.segments) > 0,
                                               null, { timeout: 10000 }).then(() => true, () => false);
  const contourPixels = await overlayPixels(page, 'frame-overlay');
  check('contour-over-image', contoured && contourPixels.drawn > 50, JSON.stringify(contourPixels));
  check('error-plot-none-without-estimate', Number(await page.$eval('#error-plot', (p) => p.dataset.points)) === 0
        && /No estimate/.test(await page.$eval('#error-plot', (p) => p.textContent)), 'a note instead');

  // The run's recording: the estimate at its pose in 3D beside the truth, its errors against time
  // with the requirement thresholds of eval's table.
  await page.click('#recordings li[data-id="1"]');
  const estimated = await page.waitForFunction(
    () => Number(document.getElementById('error-plot').dataset.points) > 0
      && document.getElementById('scene').dataset.estimate === 'true', null, { timeout: 20000 },
  ).then(() => true, () => false);
  const estimate = await page.$eval('#estimate-channel', (s) => s.value);
  check('estimate-chosen', estimated && estimate === '/cdff/pose_filtering/state', estimate);
  scene = await sceneOf();
  pixels = await scenePixels(page, 'scene');
  const runInfo = await page.evaluate(() => fetch('/api/recordings/1').then((r) => r.json()));
  const estimateChannel = runInfo.channels.find((c) => c.topic === estimate);
  const plotted = await page.$eval('#plot', (p) => ({ ...p.dataset }));
  check('trajectory-plot-truth-and-estimate', Number(plotted.estimates) === estimateChannel?.messages
        && Number(plotted.points) === runInfo.channels.find((c) => c.topic === '/truth/target_pose')?.messages,
        `${plotted.estimates} estimated and ${plotted.points} true positions against time`);
  const lvlh = await page.$eval('#lvlh-plot', (p) => ({ ...p.dataset }));
  const count = (topic) => runInfo.channels.find((c) => c.topic === topic)?.messages;
  check('lvlh-trajectories', Number(lvlh.chaser) === count('/truth/tf/servicer') && Number(lvlh.target) === count('/truth/tf/target')
        && Number(lvlh.estimate) === estimateChannel?.messages,
        `chaser ${lvlh.chaser}, target ${lvlh.target}, estimate ${lvlh.estimate} positions in LVLH`);
  check('3d-estimate-trajectory', Number(scene.estimateTrack) === estimateChannel?.messages && Number(scene.truthTrack) > 0,
        `${scene.estimateTrack} estimated positions of ${estimateChannel?.messages}, ${scene.truthTrack} true ones`);
  check('3d-estimate-and-truth', scene.estimate === 'true' && scene.truth === 'true' && pixels.model > 200 && pixels.truth > 50,
        `${JSON.stringify(scene)} ${JSON.stringify(pixels)}`);
  const errors = await page.evaluate((channel) => fetch(`/api/recordings/1/errors?${new URLSearchParams({ estimate: channel, max_points: '4000' })}`)
    .then((r) => r.json()), estimate);
  const table = await page.evaluate(() => fetch('/api/requirements').then((r) => r.json()));
  const plot = await page.$eval('#error-plot', (p) => ({ ...p.dataset }));
  const drawn = JSON.parse(plot.thresholds);
  const distinct = (values) => [...new Set(values.filter((v) => v !== null))].sort((a, b) => a - b);
  const allowed = (quantity) => table.pose.filter((r) => r.quantity === quantity).map((r) => r.threshold);
  check('error-plot-points', Number(plot.points) === errors.t.length && errors.t.length > 10,
        `${plot.points} errors plotted, ${errors.t.length} served`);
  check('error-plot-thresholds',
        JSON.stringify(drawn.position_error_m) === JSON.stringify(distinct(errors.position_threshold_m))
        && JSON.stringify(drawn.angle_error_deg) === JSON.stringify(distinct(errors.angle_threshold_deg))
        && ['position_error_m', 'angle_error_deg'].every((q) => drawn[q].length > 0 && drawn[q].every((v) => allowed(q).includes(v))),
        `${plot.thresholds} (requirements ${plot.requirements})`);
  const legend = await page.$$eval('#error-plot .u-legend .u-label', (ls) => ls.map((l) => l.textContent));
  check('error-plot-threshold-lines', legend.some((l) => l.startsWith('position threshold'))
        && legend.some((l) => l.startsWith('attitude threshold')), legend.join(' | '));
  await page.screenshot({ path: path.join(out, 'replay-3d.png'), fullPage: true });
  await page.locator('#scene').screenshot({ path: path.join(out, 'replay-scene.png') });
  await page.locator('#error-plot').screenshot({ path: path.join(out, 'replay-errors.png') });
} catch (e) {
  check('browser', false, e.message);
}
await closeAndFinish(browser, server, consoleErrors);
