// The page's camera in Debian's headless Chromium, its camera a video file (Chromium's fake capture
// device plays a y4m in a loop): the camera button pressed on FaceCap, the socket's weights events
// logged for `seconds`, written as JSON for camera_test.py.
//   node camera_test.mjs NODE_MODULES SERVICE_URL VIDEO.y4m SECONDS OUT.json
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';

const [modules, service, video, seconds, out] = process.argv.slice(2);
const { chromium } = await import(pathToFileURL(join(modules, 'playwright-core/index.mjs')).href);
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
         '--use-fake-device-for-media-stream', '--use-fake-ui-for-media-stream', `--use-file-for-fake-video-capture=${video}`],
});
const page = await browser.newPage({ viewport: { width: 1400, height: 900 } });
const errors = [];
page.on('pageerror', (e) => errors.push(e.message));
page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
await page.goto(service + '/#rig=facecap&w=');
await page.waitForFunction(() => window.facespace && window.facespace.state.liveFrames > 0, null, { timeout: 30000 });
// The video's frames carry their number (camera_test.py): ten 16-pixel squares along the top, black 0,
// white 1, the lowest bit first. Read from each frame the tracker is handed.
await page.evaluate(() => {
  const c = document.createElement('canvas');
  c.width = 160; c.height = 16;
  const g = c.getContext('2d', { willReadFrequently: true });
  window.facespace.cameraHook = (video) => {
    g.drawImage(video, 0, 0, 160, 16, 0, 0, 160, 16);
    const px = g.getImageData(0, 0, 160, 16).data;
    let n = 0;
    for (let b = 0; b < 10; ++b) if (px[4 * (8 * 160 + 16 * b + 8)] > 128) n |= 1 << b;
    return n;
  };
});
await page.locator('#say-cam').click();
let started = true;
await page.waitForFunction(() => (window.facespace.state.cameraFrames || 0) > 0, null, { timeout: 60000 }).catch(() => { started = false; });
const t0 = Date.now();
while (started && Date.now() - t0 < 1000 * Number(seconds)) await page.waitForTimeout(500);
const result = await page.evaluate(() => ({
  log: window.facespace.state.cameraLog || [],
  found: window.facespace.state.cameraFrames || 0,
  status: document.getElementById('say-state').textContent,
  on: document.getElementById('say-cam').classList.contains('on'),
  kinds: window.facespace.state.liveKinds || {},
  points: window.facespace.state.cameraPoints || [],
}));
await page.locator('#say-cam').click();
result.off = !(await page.evaluate(() => document.getElementById('say-cam').classList.contains('on')));
// Stopped: the recording saved as a motion (the weights' keys).
const [saved] = await Promise.all([page.waitForEvent('download', { timeout: 10000 }).catch(() => null),
  page.locator('#say-state button').click().catch(() => null)]);
result.motion = saved ? JSON.parse((await import('node:fs')).readFileSync(await saved.path(), 'utf8')) : null;
result.motionName = saved ? saved.suggestedFilename() : null;
result.errors = errors.filter((e) => !/GL Driver|favicon/.test(e)).slice(0, 5);
await page.screenshot({ path: out.replace(/\.json$/, '.png') });
writeFileSync(out, JSON.stringify(result));
await browser.close();
