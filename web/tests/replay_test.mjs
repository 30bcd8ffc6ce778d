// The Replay page in a real browser (Playwright driving Debian's Chromium, headless), against
// `cdff serve` on a recording that `cdff sim` writes first. Checks: the page loads with no
// console error; scrubbing the timeline shows the frame of that time (its time stamp, and the
// same JPEG as the server's image of that frame); playing advances the frame; the pose plot has
// the channel's points. Screenshots go to OUT_DIR.
// usage: node replay_test.mjs CDFF OUT_DIR   (NODE_PATH: the build's web/node_modules)
import path from 'node:path';
import { check, finish, launchChromium, simulate, startServer, testArguments } from './harness.mjs';

const { cdff, out } = testArguments('replay_test.mjs');
const recording = path.join(out, 'replay.mcap');
simulate(cdff, recording);

const { server, url } = await startServer(cdff, [recording]);
const browser = await launchChromium();
const consoleErrors = [];
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(e.message));
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
} catch (e) {
  check('browser', false, e.message);
} finally {
  await browser.close();
  server.kill('SIGTERM');
}
check('no-console-error', consoleErrors.length === 0, consoleErrors.join(' | '));
const code = server.exitCode ?? await new Promise((resolve) => server.on('exit', resolve));
check('serve-stops-on-sigterm', code === 0, `exit ${code}`);
finish();
