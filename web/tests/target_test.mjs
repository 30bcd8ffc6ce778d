// Target selection on the Live page in a real browser (Playwright driving Debian's Chromium,
// headless): a live far-range run (dfpcs/far_range_tracking.yaml with its automatic designation
// off, so that only the user starts the track) on a far-range approach that `cdff sim` writes
// first. The track waits UNINITIALISED; the test pauses the run (Idle) and drags a box around the
// image's centre, where the servicer points at the target, on the decimated image the page shows,
// then resumes it; the designation goes
// through POST /api/live/designation (the external API's designateTarget) at the full
// resolution; the DFPC designates that box (source "user"), the track becomes TRACKING and its
// bearings follow the truth's direction to the target. No console error. Screenshots go to
// OUT_DIR.
// usage: node target_test.mjs CDFF OUT_DIR   (NODE_PATH: the build's web/node_modules)
import { spawnSync } from 'node:child_process';
import { readFileSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import {
  check, closeAndFinish, launchChromium, openPage, startServer, testArguments,
} from './harness.mjs';

const { cdff, out } = testArguments('target_test.mjs');

// 40 s of the far-range approach at 400 m (the 1024x1024 camera at 1 Hz; nearer the end of the
// approach than its start, where the target shows as glints in some images only), the first
// evaluation draw's seed (data/evaluation/draws.yaml).
const recording = path.join(out, 'far.mcap');
const sim = spawnSync(cdff, ['sim', 'far_range_approach', '-o', recording, '--duration', '40',
                             '--seed', '900001', '-q',
                             '--set', 'servicer.trajectory.start=[0,-400,0]',
                             '--set', 'servicer.trajectory.end=[0,-360,0]'], { encoding: 'utf8' });
if (sim.status !== 0) {
  console.error(`FAIL: cdff sim exited with ${sim.status}: ${sim.stderr}`);
  process.exit(1);
}

// The far-range graph with its automatic designation off: the user's box is what starts it.
const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const graph = path.join(out, 'far_range_user.yaml');
const text = readFileSync(path.join(root, 'dfpcs/far_range_tracking.yaml'), 'utf8');
const automaticOff = text.replace(/( {4}dfi: FixedBlob\n)/, '$1    parameters: {automatic: false}\n');
if (automaticOff === text) {
  console.error('FAIL: dfpcs/far_range_tracking.yaml has no designate node with dfi FixedBlob');
  process.exit(1);
}
writeFileSync(graph, automaticOff);

// The far camera: 35 mm lens, 5.5 um pixels (data/scenarios/far_range_approach.yaml).
const FOCAL_PX = 0.035 / 5.5e-6;
const SIZE = 1024;
const BOX = 48;  // full-resolution pixels, around the image's centre

const { server, url } = await startServer(cdff, [recording, '--graph', graph], { cwd: root });
const browser = await launchChromium();
const consoleErrors = [];
const bearings = [];  // the stream's bearing frames, as the server sent them
const waitFor = (page, fn, arg, timeout = 60000) =>
  page.waitForFunction(fn, arg, { timeout }).then(() => true, () => false);
try {
  const page = await openPage(browser, { width: 1280, height: 1000 }, consoleErrors);
  page.on('websocket', (ws) => ws.on('framereceived', ({ payload }) => {
    if (typeof payload !== 'string') return;
    const frame = JSON.parse(payload);
    if (frame.type === 'bearing') bearings.push(frame);
  }));
  await page.goto(`${url}#live`);
  await page.waitForSelector('#live[data-ready="true"]', { timeout: 30000 });
  await page.selectOption('#live-graph', graph);
  await page.selectOption('#live-recording', '0');
  await page.selectOption('#live-speed', '2');
  await page.click('#live-start');
  check('running', await waitFor(page, () => document.body.dataset.liveState === 'running'),
        await page.$eval('#live-state', (p) => p.textContent));

  // The camera image, decimated for the page; the track waits for a designation.
  check('camera-image', await waitFor(page, () => Number(document.getElementById('live-frame').dataset.t) >= 2),
        await page.$eval('#live-frame-caption', (c) => c.textContent));
  const row = '#live-dfpcs tr[data-name="far_range_tracking"]';
  const trackBefore = await page.$eval(row, (r) => r.dataset.track);
  check('waits-for-designation', trackBefore === 'UNINITIALISED' && bearings.length === 0,
        `track ${trackBefore}, ${bearings.length} bearings`);
  const shown = await page.$eval('#live-frame', (img) => ({ w: img.naturalWidth, h: img.naturalHeight }));
  check('image-decimated', shown.w < SIZE, `shown at ${shown.w}x${shown.h} of ${SIZE}x${SIZE}`);

  // The run paused (Idle: the input waits, the image stays) while the user draws, as on a
  // ground station: the box goes in at the paused stream time, and the DFPC takes its template
  // from the next image whatever the time the drawing took (the track depends on that image:
  // with this recording a box given at 3 s or 4 s is tracked within 2 px RMS, one at 5 s is not).
  await page.click('#live-idle');
  check('idle-to-draw', await waitFor(page, () => document.body.dataset.liveState === 'idle'),
        await page.$eval('#live-state', (p) => p.textContent));
  const paused = await page.evaluate(() => fetch('/api/live').then((res) => res.json()));

  // Drag a box around the image's centre, in screen pixels of the image as shown.
  const r = await page.$eval('#live-overlay', (o) => {
    const b = o.getBoundingClientRect();
    return { left: b.left, top: b.top, width: b.width, height: b.height };
  });
  const scale = r.width / SIZE;
  const from = { x: r.left + (SIZE / 2 - BOX / 2) * scale, y: r.top + (SIZE / 2 - BOX / 2) * scale };
  const to = { x: from.x + BOX * scale, y: from.y + BOX * scale };
  const designated = page.waitForResponse((res) => res.url().includes('/api/live/designation'));
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  await page.mouse.move((from.x + to.x) / 2, (from.y + to.y) / 2, { steps: 4 });
  await page.mouse.move(to.x, to.y, { steps: 4 });
  await page.screenshot({ path: path.join(out, 'live-target-drag.png') });
  await page.mouse.up();
  const answer = await designated;
  const body = await answer.json();
  const d = body.designation;
  // The box in full-resolution pixels, whatever the page's decimation: within a screen pixel of
  // the drag's corners (one screen pixel is 1/scale camera pixels).
  const tolerance = 1 / scale + 1;
  check('designation-accepted', answer.status() === 200, JSON.stringify(body));
  check('designation-full-resolution', d && Math.abs(d.x - (SIZE / 2 - BOX / 2)) <= tolerance
        && Math.abs(d.y - (SIZE / 2 - BOX / 2)) <= tolerance && Math.abs(d.width - BOX) <= tolerance
        && Math.abs(d.height - BOX) <= tolerance && d.image.width === SIZE,
        JSON.stringify(d));
  check('designation-at-paused-time', d && Math.abs(d.t - paused.t) < 1e-6 && d.image.t <= d.t && d.t < 5,
        `designated at ${d?.t} s, paused at ${paused.t} s, the image of ${d?.image.t} s`);
  await page.click('#live-resume');
  check('resumed', await waitFor(page, () => document.body.dataset.liveState === 'running'),
        await page.$eval('#live-state', (p) => p.textContent));
  check('designation-shown', await waitFor(page, () => document.getElementById('live-shape-designation') !== null
        && document.getElementById('live-designation').textContent.includes('far_range_tracking')),
        await page.$eval('#live-designation', (p) => p.textContent));

  // Far-range tracking starts from it: the DFPC's designated region (the user's), TRACKING,
  // bearings designated by the user.
  check('region-designated', await waitFor(page, () => document.getElementById('live-overlay').dataset.designatedT !== undefined),
        await page.$eval('#live-overlay', (o) => JSON.stringify(o.dataset)));
  check('tracking', await waitFor(page, (sel) => document.querySelector(sel)?.dataset.track === 'TRACKING', row),
        await page.$eval(row, (tr) => tr.textContent));
  check('bearings-shown', await waitFor(page, () => Number(document.getElementById('live-bearing').dataset.count) >= 10),
        await page.$eval('#live-bearing', (p) => p.textContent));
  check('match-drawn', await waitFor(page, () => document.getElementById('live-shape-region-match') !== null),
        await page.$eval('#live-overlay', (o) => JSON.stringify(o.dataset)));
  await page.screenshot({ path: path.join(out, 'live-target-tracking.png') });
  check('recording-consumed', await waitFor(page, () => /consumed/.test(document.getElementById('live-state').textContent), undefined, 120000),
        await page.$eval('#live-state', (p) => p.textContent));

  // Every bearing of the run against the truth's direction to the target's centre of mass
  // (servicer frame), from the recording: the box was centred on the camera's axis, on which the servicer points
  // the target (0.01 deg of jitter); the tracked point starts within the drag's rounding of it.
  const truth = await page.evaluate(() => fetch('/api/recordings/0/poses?channel=/truth/target_pose&max_points=100000')
    .then((res) => res.json()));
  const errors = [];
  for (const b of bearings) {
    let best = -1;
    for (let i = 0; i < truth.t.length; i += 1)
      if (best < 0 || Math.abs(truth.t[i] - b.t) < Math.abs(truth.t[best] - b.t)) best = i;
    if (best < 0 || Math.abs(truth.t[best] - b.t) > 0.05 || truth.frame !== b.frame) continue;
    const p = [truth.x[best], truth.y[best], truth.z[best]];
    const u = b.direction;
    const dot = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
    const cross = Math.hypot(p[1] * u[2] - p[2] * u[1], p[2] * u[0] - p[0] * u[2], p[0] * u[1] - p[1] * u[0]);
    errors.push(Math.atan2(cross, dot) * FOCAL_PX);  // pixels of the far camera
  }
  errors.sort((a, b) => a - b);
  const rms = Math.sqrt(errors.reduce((s, e) => s + e * e, 0) / Math.max(1, errors.length));
  const max = errors.at(-1) ?? NaN;
  const figures = `${errors.length} of ${bearings.length} bearings compared, RMS ${rms.toFixed(2)} px, `
    + `max ${max.toFixed(2)} px (${(max / FOCAL_PX * 1e3).toFixed(3)} mrad)`;
  console.log(`bearing vs truth: ${figures}`);
  check('bearings-by-user', bearings.length >= 10 && bearings.every((b) => b.designation === 'user'),
        `${bearings.length} bearings, designations ${[...new Set(bearings.map((b) => b.designation))].join(', ')}`);
  // Bound: the drag's rounding (a screen pixel, 1/scale camera pixels: 1.9 px here), the pointing
  // jitter (0.01 deg: 1.1 px), the camera's 0.05 m offset from the servicer's axis (0.8 px at
  // 400 m) and the matcher's tracked point (3 px RMS, tests/far_range) add up to 7 px; the RMS
  // is bounded near today's figures (1.3-1.6 px RMS, 1.7-4.3 px at most, for a box given at 3 or
  // 4 s; 3.7 px RMS when given at 2 s).
  check('bearings-near-truth', errors.length >= 30 && max < 7 && rms < 4.5, figures);
  check('bearing-text', /mrad from \/truth\/target_pose/.test(await page.$eval('#live-bearing', (p) => p.textContent)),
        await page.$eval('#live-bearing', (p) => p.textContent));

  // A box that leaves the image (the page clamps a drag to the image; another client may not):
  // refused, naming the image's size.
  const refused = await page.request.post(`${url}api/live/designation`, { data: { x: 1000, y: 10, w: 48, h: 48 } });
  const reason = (await refused.json()).error ?? '';
  check('outside-refused', refused.status() === 400 && reason.includes('leaves the 1024x1024 image'),
        `${refused.status()}: ${reason}`);
  await page.click('#live-stop');
  check('stopped', await waitFor(page, () => document.body.dataset.liveState === 'none'),
        await page.$eval('#live-state', (p) => p.textContent));
} catch (e) {
  check('browser', false, e.message);
}
await closeAndFinish(browser, server, consoleErrors);
