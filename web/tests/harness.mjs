// What the browser tests share: their arguments, a log of checks, a short simulated approach,
// `cdff serve` started on a free port, and Debian's Chromium driven by Playwright (headless).
import { spawn, spawnSync } from 'node:child_process';
import { existsSync, mkdirSync, rmSync } from 'node:fs';
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
    args: ['--disable-dev-shm-usage', ...(process.getuid?.() === 0 ? ['--no-sandbox'] : [])],
  });
}
