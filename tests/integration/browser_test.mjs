// The character-creator page in headless Chromium (Debian's), against the real service: loaded
// from the service itself and from another origin (CORS). Prints ok/FAIL lines like the shell tests.
// usage: node browser_test.mjs SERVICE_URL OTHER_ORIGIN_PAGE_URL OUT_DIR
import { chromium } from 'playwright-core';
import { createRequire } from 'node:module';
import fs from 'node:fs';

const [service, otherPage, outDir] = process.argv.slice(2);
const require = createRequire(import.meta.url);
let pass = 0, fail = 0;
const check = (what, cond) => { if (cond) { pass++; console.log('ok   ' + what); } else { fail++; console.log('FAIL ' + what); } };
// A speed bar (suite.py's bar): a figure in the test command, printed fast or slow; held with FACESPACE_BARS=1.
const bar = (what, cond) => (process.env.FACESPACE_BARS === '1' ? check('bar: ' + what, cond) : console.log((cond ? 'fast ' : 'slow ') + what));

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
         '--use-fake-device-for-media-stream', '--use-fake-ui-for-media-stream'],  // A microphone that beeps.
});

// A digest of the preview's pixels, drawn into a canvas in the page.
const previewDigest = (page) => page.evaluate(() => {
  const img = document.getElementById('preview');
  if (!img.complete || !img.naturalWidth) return null;
  const c = document.createElement('canvas');
  c.width = img.naturalWidth; c.height = img.naturalHeight;
  const x = c.getContext('2d');
  x.drawImage(img, 0, 0);
  const d = x.getImageData(0, 0, c.width, c.height).data;
  let h = 0;
  for (let i = 0; i < d.length; i += 7) h = (h * 31 + d[i]) >>> 0;
  return h;
});

async function run(label, url, shot) {
  const context = await browser.newContext({ acceptDownloads: true, viewport: { width: 1500, height: 1000 } });
  const page = await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(url);
  await page.waitForFunction(() => document.querySelectorAll('.shape').length > 0, null, { timeout: 30000 });
  await page.waitForFunction(() => document.getElementById('preview').naturalWidth === 512, null, { timeout: 30000 });
  check(`${label}: the page loads the rig list and one slider per shape (52)`,
    (await page.locator('#rig option').count()) >= 1 && (await page.locator('.shape').count()) === 52);
  const groups = await page.locator('#controls h2').allTextContents();
  check(`${label}: sliders are grouped by face region, top down (${groups.join(', ')})`,
    groups.join(',') === 'brow,eye,cheek,nose,jaw,mouth,tongue');
  // A second render of the same face (the live socket's first frame asks for one) may be decoding
  // the moment the first is judged: wait for the image that is there to be whole.
  let before = await previewDigest(page);
  for (let i = 0; i < 100 && before === null; ++i) { await page.waitForTimeout(100); before = await previewDigest(page); }
  check(`${label}: the first preview is a render`, before !== null);
  await page.waitForFunction(() => window.facespace.state.liveFrames > 0, null, { timeout: 10000 }).catch(() => {});
  const liveFrames = await page.evaluate(() => window.facespace.state.liveFrames || 0);
  check(`${label}: the WebGL mesh comes over the live socket of the API's origin (${liveFrames} frames)`, liveFrames > 0);
  if (label === 'same-origin') {  // On a 1400 x 900 window: both views in sight, no number box cut.
    await page.setViewportSize({ width: 1400, height: 900 });
    await page.waitForTimeout(200);
    const gl = await page.locator('#gl').boundingBox();
    const panel = await page.locator('#controls').boundingBox();
    const inner = await page.evaluate(() => document.getElementById('controls').clientWidth);
    const num = await page.locator('input[aria-label="jawOpen value"]').boundingBox();
    check(`${label}: at 1400 x 900 the WebGL view is beside the render, above the fold (${Math.round(gl.x)}, ${Math.round(gl.y)}, ${Math.round(gl.width)} px)`,
      gl.y + gl.height <= 900 && gl.x + gl.width <= 1400 && gl.width >= 300);
    check(`${label}: the number boxes sit inside the panel (right edge ${Math.round(num.x + num.width)} <= ${Math.round(panel.x + inner)})`,
      num.x + num.width <= panel.x + inner && num.width >= 40);
    await page.setViewportSize({ width: 1500, height: 1000 });
    await page.locator('#share').click();
    await page.waitForSelector('#notice:not([hidden])', { timeout: 5000 }).catch(() => {});
    check(`${label}: Share says what it did (${(await page.locator('#notice').textContent()).slice(0, 40)})`,
      (await page.locator('#notice').isVisible()) && /[Ll]ink/.test(await page.locator('#notice').textContent()));
  }

  await page.locator('input[aria-label="jawOpen"]').fill('0.9');
  let after = before;
  // null: a new image is still decoding; wait for it rather than judge it.
  for (let i = 0; i < 100 && (after === before || after === null); ++i) { await page.waitForTimeout(100); after = await previewDigest(page); }
  check(`${label}: moving a slider changes the preview`, after !== null && after !== before);
  check(`${label}: the sum is shown (0.9)`, (await page.locator('#sum').textContent()) === '0.9');
  check(`${label}: no warning while the sum is within 1`, await page.locator('#warning').isHidden());

  await page.locator('input[aria-label="mouthSmile_L"]').fill('0.8');
  await page.waitForSelector('#warning:not([hidden])', { timeout: 15000 }).catch(() => {});
  const warning = await page.locator('#warning').textContent();
  check(`${label}: the symmetric partner moves with it (mouthSmile_R = 0.8)`,
    (await page.locator('input[aria-label="mouthSmile_R"]').inputValue()) === '0.8');
  check(`${label}: the sum above 1 shows the extrapolation warning (${warning.trim().slice(0, 60)}...)`,
    (await page.locator('#warning').isVisible()) && /extrapolation: sum of weights 2\.5 exceeds 1/.test(warning) && !/xtrapolation: extrapolation/.test(warning));
  await page.locator('input[aria-label="eyeBlink_L value"]').fill('1.5');
  await page.locator('input[aria-label="eyeBlink_L value"]').press('Enter');
  await page.waitForFunction(() => /out of range: .*eyeBlink_L/.test(document.getElementById('warning').textContent), null, { timeout: 15000 }).catch(() => {});
  check(`${label}: a weight outside its range is named, and its row marked`,
    /out of range: .*eyeBlink_L/.test(await page.locator('#warning').textContent()) &&
    (await page.locator('.shape.out').count()) >= 1);

  const coverage = await page.evaluate(() => window.facespace.gl.coverage());
  check(`${label}: the WebGL2 view draws the float32 mesh (${(coverage * 100).toFixed(1)}% of pixels)`, coverage > 0.05);

  const hash = await page.evaluate(() => location.hash);
  check(`${label}: the URL holds the weights (${hash.slice(0, 50)}...)`, /rig=facecap&w=.*jawOpen:0.9/.test(hash));

  const [download] = await Promise.all([page.waitForEvent('download'), page.locator('#dl-glb').click()]);
  const glb = `${outDir}/${label}.glb`;
  await download.saveAs(glb);
  const validator = require('gltf-validator');
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(glb)));
  check(`${label}: the downloaded glb is valid glTF (${report.issues.numErrors} errors, ${fs.statSync(glb).size} bytes)`,
    report.issues.numErrors === 0 && fs.statSync(glb).size > 10000);
  const [wdl] = await Promise.all([page.waitForEvent('download'), page.locator('#dl-json').click()]);
  const weights = JSON.parse(fs.readFileSync(await wdl.path(), 'utf8')).weights;
  check(`${label}: the weights download is the vector shown`, weights.jawOpen === 0.9 && weights.mouthSmile_R === 0.8 && weights.eyeBlink_L === 1.5);

  // View switch and camera drag change the preview.
  const waitChange = async (from) => {
    let d = from;
    for (let i = 0; i < 150 && (d === from || d === null); ++i) { await page.waitForTimeout(100); d = await previewDigest(page); }
    return d;
  };
  let d0 = await previewDigest(page);
  await page.locator('#view').selectOption('heatmap');
  let d1 = await waitChange(d0);
  check(`${label}: switching to the heatmap view changes the preview`, d1 !== d0 && /view=heatmap/.test(await page.evaluate(() => location.hash)));
  const box = await page.locator('#preview').boundingBox();
  await page.mouse.move(box.x + 200, box.y + 200);
  await page.mouse.down();
  await page.mouse.move(box.x + 280, box.y + 210, { steps: 5 });
  await page.mouse.up();
  const d2 = await waitChange(d1);
  check(`${label}: dragging the preview turns the camera (yaw ${await page.evaluate(() => window.facespace.state.yaw)})`,
    d2 !== d1 && (await page.evaluate(() => window.facespace.state.yaw)) === 40);
  // Randomise is seeded: the same seed gives the same face.
  await page.locator('#seed').fill('7');
  await page.locator('#randomise').click();
  const first = await page.evaluate(() => location.hash);
  await page.locator('#seed').fill('7');
  await page.locator('#randomise').click();
  const again = await page.evaluate(() => location.hash);
  await page.locator('#randomise').click();
  const third = await page.evaluate(() => location.hash);
  check(`${label}: Randomise with seed 7 twice gives the same weights, the next seed others`, first === again && first !== third && /w=.+/.test(first));
  await page.locator('#reset').click();
  await page.waitForTimeout(200);
  // FaceCap's file has defaults (a capture frame: jawOpen 0.1371, ..., sum 4.57); its manifest does
  // not ask to start there, so Reset is the neutral face; eyeBlink_L was 1.5.
  check(`${label}: Reset returns to the neutral face`, (await page.locator('input[aria-label="jawOpen value"]').inputValue()) === '0' &&
    (await page.locator('input[aria-label="browInnerUp value"]').inputValue()) === '0' &&
    (await page.locator('input[aria-label="eyeBlink_L value"]').inputValue()) === '0');

  await page.evaluate(() => window.facespace.loadRig('nobody').catch((e) => { document.getElementById('error').textContent = 'Error: ' + e.message; document.getElementById('error').hidden = false; }));
  check(`${label}: a service error shows its problem detail`, /no rig with id 'nobody'/.test(await page.locator('#error').textContent()));

  // A shared link reproduces the face.
  const shared = await context.newPage();
  await shared.goto(url.split('#')[0] + hash);
  await shared.reload();
  await shared.waitForFunction(() => document.querySelectorAll('.shape').length > 0, null, { timeout: 30000 });
  check(`${label}: opening the shared link restores the sliders`,
    (await shared.locator('input[aria-label="jawOpen"]').inputValue()) === '0.9' &&
    (await shared.locator('input[aria-label="eyeBlink_L value"]').inputValue()) === '1.5');
  if (shot) {
    await shared.waitForFunction(() => document.getElementById('preview').naturalWidth === 512, null, { timeout: 30000 });
    await shared.waitForTimeout(500);
    await shared.screenshot({ path: shot });
    console.log('screenshot: ' + shot);
  }
  check(`${label}: no script errors in the page (${errors.slice(0, 2).join('; ')})`, errors.filter((e) => !/404|nobody/.test(e)).length === 0);
  await context.close();
}

// A rig with controls (the MakeHuman face): grouped control sliders, two-sided, mirrored pairs.
async function controls(url, shot) {
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  await page.goto(url);
  await page.waitForFunction(() => document.querySelectorAll('.shape').length > 100, null, { timeout: 60000 });
  await page.waitForFunction(() => document.getElementById('preview').naturalWidth === 512, null, { timeout: 60000 });
  const groups = await page.locator('#controls h2').allTextContents();
  check(`controls: the MakeHuman rig shows its 146 controls grouped (${groups.join(', ')})`,
    (await page.locator('.shape').count()) === 146 && groups.includes('nose') && groups.includes('eyes'));
  const shownAtFirst = await page.locator('.shape:visible').count();
  check(`controls: 146 controls open folded, only the first group unfolded (${shownAtFirst} rows shown)`, shownAtFirst > 0 && shownAtFirst < 60);
  await page.locator('#filter').fill('eye bag');
  const found = await page.locator('.shape:visible').evaluateAll((rows) => rows.map((r) => r.dataset.name));
  check(`controls: the filter "eye bag" shows just the eye-bag controls, unfolded (${found.join(', ')}; ${await page.locator('#filter-count').textContent()})`,
    found.length >= 2 && found.every((n) => /eye-bag/.test(n)) && found.includes('eyes/l-eye-bag-decr|incr') &&
    (await page.locator('#filter-count').textContent()) === `${found.length} of 146`);
  const before = await previewDigest(page);
  await page.locator('input[aria-label="eyes/l-eye-bag-decr|incr"]').fill('0.7');
  await page.locator('#filter').fill('nose-trans-down');
  await page.locator('input[aria-label="nose/nose-trans-down|up"]').fill('-0.4');
  await page.locator('#filter').fill('');
  check('controls: clearing the filter shows the groups folded as before', (await page.locator('.shape:visible').count()) === shownAtFirst);
  let after = before;
  for (let i = 0; i < 150 && after === before; ++i) { await page.waitForTimeout(100); after = await previewDigest(page); }
  await page.waitForFunction(() => document.getElementById('sum').textContent === '1.8', null, { timeout: 15000 }).catch(() => {});
  check('controls: a two-sided control below 0 changes the face; the sum counts the shapes it drives (0.4 + 0.7 + 0.7)',
    after !== before && (await page.locator('#sum').textContent()) === '1.8');
  check('controls: the left eye-bag control moves the right one',
    (await page.locator('input[aria-label="eyes/r-eye-bag-decr|incr"]').inputValue()) === '0.7');
  const hash = await page.evaluate(() => location.hash);
  check(`controls: the URL holds control values (${hash.slice(0, 60)})`, /#rig=makehuman&c=.*nose%2Fnose-trans-down%7Cup:-0.4/.test(hash));
  await page.screenshot({ path: shot });
  console.log('screenshot: ' + shot);
  await page.close();
}

// '#rig=facecap&w=' starts from all weights 0 (FaceCap's file has non-zero defaults).
await run('same-origin', service + '/#rig=facecap&w=', `${outDir}/page.png`);

{  // A new user opening the page with no link: FaceCap at its neutral face, no warning.
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  await page.goto(service + '/');
  await page.waitForFunction(() => document.getElementById('preview').naturalWidth === 512, null, { timeout: 30000 });
  await page.waitForTimeout(300);
  const sum = await page.locator('#sum').textContent();
  check(`first visit: the page opens at the neutral face (sum ${sum}) with no warning`,
    sum === '0' && await page.locator('#warning').isHidden());
  await page.close();
}
{  // Say: the face speaks a typed line with its audio, the WebGL mouth following the audio's own clock;
   // MakeHuman, its expressions derived, has one too (a rig without a mouth has none: the unit tests).
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  await page.goto(service + '/#rig=facecap&w=');
  await page.waitForFunction(() => document.getElementById('preview').naturalWidth === 512 && !document.getElementById('views').classList.contains('loading'), null, { timeout: 30000 });
  check('say: the Say bar shows for a rig with a mouth', await page.locator('#say').isVisible());
  const before = await page.evaluate(() => window.facespace.state.meshUpdates || 0);
  await page.locator('#say-text').fill('Hello, my name is Bob. Please pass the map.');
  await page.locator('#say-go').click();
  // Over the live socket: audio chunks played as they come (Web Audio), the mouth on their clock.
  await page.waitForFunction(() => { const s = window.facespace.state.speech; return s && s.live && s.base !== null && s.ctx.currentTime - s.base > 1.0; },
                             null, { timeout: 20000 });
  const max = await page.evaluate(() => window.facespace.state.speechMax);
  await page.waitForFunction(() => !window.facespace.state.speech, null, { timeout: 20000 });
  const updates = await page.evaluate(() => window.facespace.state.meshUpdates) - before;
  const status = await page.locator('#say-state').textContent();
  check(`say: over the live socket the audio plays and the WebGL face follows it (${updates} meshes over the line, ` +
        `largest weight ${max.toFixed(2)}; "${status}")`, updates >= 10 && max > 0.3 && /espeak-ng, live/.test(status));
  // The microphone: Chromium's fake device (a beep) captured at 16 kHz and sent over the socket while the
  // server listens; its answers come back as events.
  await page.locator('#say-mic').click();
  await page.waitForFunction(() => (window.facespace.state.micChunks || 0) > 40, null, { timeout: 20000 });
  const mic = await page.evaluate(() => ({ chunks: window.facespace.state.micChunks, on: document.getElementById('say-mic').classList.contains('on') }));
  await page.locator('#say-mic').click();
  check(`say: the mic button sends the microphone's PCM over the live socket (${mic.chunks} chunks of 32 ms) and stops`,
        mic.chunks > 40 && mic.on && !(await page.evaluate(() => document.getElementById('say-mic').classList.contains('on'))));
  check('say: when the line ends the face is the sliders\' again', await page.evaluate(() => !window.facespace.state.speech) &&
        await page.locator('#say-stop').isHidden());
  // The typed line as a video: a WebM file (EBML's magic number first) of the face saying it.
  const [video] = await Promise.all([page.waitForEvent('download', { timeout: 60000 }), page.locator('#say-webm').click()]);
  const webm = fs.readFileSync(await video.path());
  check(`say: the webm button saves the line as a WebM video (${webm.length} bytes, ${video.suggestedFilename()})`,
    webm.length > 10000 && webm.readUInt32BE(0) === 0x1a45dfa3 && video.suggestedFilename() === 'facecap.webm');
  check('say: no VRM button for a rig without a skeleton (FaceCap)', await page.locator('#dl-vrm').isHidden());
  await page.locator('#rig').selectOption('makehuman');
  await page.waitForFunction(() => window.facespace.state.ready === 'makehuman', null, { timeout: 30000 });
  // MakeHuman's expressions are derived from FaceCap's (issue 63): it has a mouth to speak with.
  check('say: the Say bar shows for MakeHuman, its mouth derived', await page.locator('#say').isVisible());
  check(`say: no script errors (${errors.slice(0, 2).join('; ')})`, errors.length === 0);
  await page.close();
}
{  // The WebGL view follows a dragged slider; a rig switch shows the new face soon, never the old one.
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  await page.goto(service + '/#rig=facecap&w=');
  await page.waitForFunction(() => document.getElementById('preview').naturalWidth === 512 && !document.getElementById('views').classList.contains('loading'), null, { timeout: 30000 });
  // A drag as a browser delivers it: an input event each frame (60 a second) for 1 s, in the page (the
  // test driver's own mouse moves come at about 11 a second here).
  await page.waitForFunction(() => window.facespace.state.liveFrames > 0, null, { timeout: 10000 });
  let meshRequests = 0;
  page.on('request', (r) => { if (r.url().includes('/mesh')) ++meshRequests; });
  const drag = await page.evaluate(async () => {
    const slider = document.querySelector('input[aria-label="jawOpen"]');
    const before = window.facespace.state.meshUpdates, frames = window.facespace.state.liveFrames;
    let inputs = 0;
    const t = performance.now();
    while (performance.now() - t < 1000) {
      slider.value = String(((inputs % 50) + 1) / 50);
      slider.dispatchEvent(new Event('input', { bubbles: true }));
      ++inputs;
      await new Promise((r) => setTimeout(r, 16));
    }
    return { updates: window.facespace.state.meshUpdates - before, frames: window.facespace.state.liveFrames - frames, inputs };
  });
  const during = drag.updates, inputs = drag.inputs;
  check(`drag: the WebGL view follows a 1 s slider drag (${during} mesh updates for ${inputs} input events)`, during >= 1);
  bar(`drag: ... at least 10 mesh updates in the second (${during})`, during >= 10);
  check(`drag: over the live socket (${drag.frames} frames, ${meshRequests} HTTP mesh requests)`, drag.frames >= 1 && meshRequests === 0);
  // The smallest frames the page can draw: delta frames, decoded by meshoptimizer's decoder (served from
  // npm at /vendor), the normals made by the view; drawn as the float32 mesh is (the same pixels but a few).
  const kinds = await page.evaluate(() => window.facespace.state.liveKinds || {});
  const deltaPixels = await page.evaluate(() => window.facespace.gl.coverage());
  check(`drag: the frames are delta frames (${JSON.stringify(kinds)}), the face drawn from them (${(deltaPixels * 100).toFixed(1)}% of pixels)`,
    (kinds.dkey || 0) >= 1 && (kinds.dlta || 0) >= 1 && deltaPixels > 0.05);
  const switched = await page.evaluate(async () => {
    const views = document.getElementById('views');
    const select = document.getElementById('rig');
    const t = performance.now();
    select.value = 'uka';
    select.dispatchEvent(new Event('change'));
    const loadingAtOnce = views.classList.contains('loading');
    while (views.classList.contains('loading') && performance.now() - t < 20000) await new Promise((r) => setTimeout(r, 5));
    return { ms: performance.now() - t, loadingAtOnce, shapes: document.querySelectorAll('.shape').length };
  });
  check(`switch: picking uka marks the views loading at once and shows her face (${switched.shapes} sliders)`,
    switched.loadingAtOnce && !(await page.evaluate(() => document.getElementById('views').classList.contains('loading'))) && switched.shapes > 100);
  bar(`switch: ... in ${Math.round(switched.ms)} ms (at most 500)`, switched.ms <= 500);
  // Her face as a VRM avatar: a glb whose JSON carries VRMC_vrm with a humanoid.
  const [avatar] = await Promise.all([page.waitForEvent('download', { timeout: 60000 }), page.locator('#dl-vrm').click()]);
  const vrm = fs.readFileSync(await avatar.path());
  const vrmJson = vrm.length > 20 ? JSON.parse(vrm.subarray(20, 20 + vrm.readUInt32LE(12)).toString('utf8')) : {};
  check(`vrm: the vrm button saves uka as a VRM 1.0 avatar (${vrm.length} bytes, ${avatar.suggestedFilename()})`,
    vrm.readUInt32LE(0) === 0x46546c67 && !!(vrmJson.extensions && vrmJson.extensions.VRMC_vrm && vrmJson.extensions.VRMC_vrm.humanoid) &&
    avatar.suggestedFilename() === 'uka.vrm');
  await page.close();
}
{  // A motion plays, pauses and scrubs: FaceCap's recorded take (its morph-weight channel).
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  await page.goto(service + '/#rig=facecap&w=');
  await page.waitForFunction(() => document.getElementById('preview').naturalWidth === 512 && !document.getElementById('motion').hidden, null, { timeout: 30000 });
  const neutral = await previewDigest(page);
  await page.selectOption('#motion-name', 'Key|Take 001|BaseLayer');
  const updates0 = await page.evaluate(() => window.facespace.state.meshUpdates);
  // The clock runs in real time: what it shows at the pause lies between the page time from the play
  // click's return to the pause click's start, and from before the play click to after the pause
  // (a loaded machine stretches the clicks themselves).
  const before = await page.evaluate(() => performance.now());
  await page.click('#motion-play');
  const playing = await page.evaluate(() => performance.now());
  await page.waitForTimeout(1500);
  const pausing = await page.evaluate(() => performance.now());
  await page.click('#motion-play');  // Pause.
  const after = await page.evaluate(() => performance.now());
  const played = await page.evaluate(() => ({ t: window.facespace.state.motion.time, playing: window.facespace.state.motion.playing, updates: window.facespace.state.meshUpdates }));
  const least = (pausing - playing) / 1000 - 0.1, most = (after - before) / 1000 + 0.1;
  await page.waitForTimeout(800);
  const paused = await page.evaluate(() => window.facespace.state.motion.time);
  await page.locator('#motion-time').fill('5');
  await page.waitForFunction(() => document.getElementById('motion-clock').textContent === '5.00 s', null, { timeout: 5000 }).catch(() => {});
  await page.waitForTimeout(1500);
  const scrubbed = await previewDigest(page);
  const sum = await page.locator('#sum').textContent();
  // The sliders show the take's weights at 5 s (as the service's check gives them), marked as driven.
  const sliders = await page.evaluate(async () => {
    const check = await fetch('/v1/rigs/facecap/check', { method: 'POST', headers: { 'content-type': 'application/json' },
                                                          body: JSON.stringify({ animation: 'Key|Take 001|BaseLayer', time: 5 }) }).then((r) => r.json());
    const rows = [...document.querySelectorAll('.shape')];
    const wrong = rows.filter((r) => Math.abs(parseFloat(r.querySelector('input[type=number]').value) - (check.weights[r.dataset.name] || 0)) > 0.001);
    return { rows: rows.length, wrong: wrong.map((r) => r.dataset.name), driven: rows.filter((r) => r.classList.contains('driven')).length,
             moving: rows.filter((r) => parseFloat(r.querySelector('input[type=number]').value) > 0.01).length };
  });
  check(`motion: the sliders show the take's weights at 5 s (${sliders.moving} above 0.01, ${sliders.wrong.length} differing from /check: ${sliders.wrong.slice(0, 3).join(', ')}; ${sliders.driven} of ${sliders.rows} marked driven)`,
    sliders.moving > 3 && sliders.wrong.length === 0 && sliders.driven === sliders.rows);
  check(`motion: the take plays in real time (${played.t.toFixed(2)} s, between ${least.toFixed(2)} and ${most.toFixed(2)} s of page time; ${played.updates - updates0} mesh updates), pauses (still ${paused.toFixed(2)} s), and scrubbing to 5 s shows another face (sum ${sum})`,
    played.t >= least && played.t <= most && played.t > 0.7 && !played.playing && paused === played.t && played.updates - updates0 >= 5 && scrubbed !== neutral && scrubbed !== null);
  await page.screenshot({ path: `${outDir}/page-motion.png` });
  await page.close();
}
{  // A phone (390 x 844): the face in the first screen, and still in view once the sliders are scrolled,
   // with the warning above it (a smile and an open jaw: the sum is over 1).
  const page = await browser.newPage({ viewport: { width: 390, height: 844 }, isMobile: true, hasTouch: true });
  await page.goto(service + '/#rig=facecap&w=jawOpen:0.6,mouthSmile_L:0.5,mouthSmile_R:0.5');
  await page.waitForFunction(() => document.getElementById('preview').naturalWidth === 512, null, { timeout: 30000 });
  await page.waitForFunction(() => !document.getElementById('warning').hidden, null, { timeout: 30000 }).catch(() => {});
  const inView = () => page.evaluate(() => {
    const box = (id) => document.getElementById(id).getBoundingClientRect();
    const warning = box('warning'), views = box('views');
    return ['preview', 'gl'].map((id) => {
      const r = box(id);
      return r.top >= 0 && r.bottom <= innerHeight && r.width >= 150;
    }).concat([warning.height > 0 && warning.top >= 0 && warning.bottom <= views.top + 1]);
  });
  const first = await inView();
  await page.evaluate(() => window.scrollBy(0, 1500));
  await page.waitForTimeout(200);
  const scrolled = await inView();
  const header = await page.locator('header').boundingBox();
  check(`phone: at 390 x 844 the face (render and WebGL view) and the warning above it are in the first screen (${first}), the header one row (${Math.round(header.height)} px), and both stay in view under scrolled sliders (${scrolled})`,
    first.every(Boolean) && scrolled.every(Boolean) && header.height < 60);
  await page.screenshot({ path: `${outDir}/page-phone.png` });
  await page.close();
}
{  // A link naming a rig or shapes this service does not have says so.
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  await page.goto(service + '/#rig=nope&w=jawOpen:0.5,noSuchShape:1');
  await page.waitForFunction(() => !document.getElementById('notice').hidden, null, { timeout: 30000 }).catch(() => {});
  const said = await page.locator('#notice').textContent();
  check(`links: an unknown rig is said, not silently replaced (${said})`, /No rig .nope./.test(said));
  await page.goto(service + '/#rig=facecap&w=jawOpen:0.5,noSuchShape:1');
  await page.reload();
  await page.waitForFunction(() => /noSuchShape/.test(document.getElementById('notice').textContent), null, { timeout: 30000 }).catch(() => {});
  check(`links: a weight the rig lacks is said (${await page.locator('#notice').textContent()})`, /left out: noSuchShape/.test(await page.locator('#notice').textContent()));
  await page.close();
}
await controls(service + '/#rig=makehuman&c=', `${outDir}/page-makehuman.png`);
// A rig whose license asks for a credit (the MMD character): the page shows it under the views.
{
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  await page.goto(service + '/#rig=uka&w=');
  await page.waitForFunction(() => document.querySelectorAll('.shape').length > 100, null, { timeout: 60000 });
  await page.waitForFunction(() => !document.getElementById('credit').hidden, null, { timeout: 15000 }).catch(() => {});
  const credit = await page.locator('#credit').textContent();
  check(`credit: the uka page shows its credit line (${credit.slice(0, 60)}...)`,
    credit.includes('CG-CA Uka (c) 2023 by Nagoya Institute of Technology, Moonshot R&D Goal 1 Avatar Symbiotic Society'));
  // Japanese names draw as glyphs: with no CJK font, あ and い are the same empty box.
  const glyphs = await page.evaluate(() => {
    const c = document.createElement('canvas');
    c.width = 64; c.height = 32;
    const x = c.getContext('2d');
    const font = getComputedStyle(document.querySelector('.shape label')).font;
    const draw = (t) => { x.clearRect(0, 0, 64, 32); x.font = font; x.fillText(t, 2, 24); return Array.from(x.getImageData(0, 0, 64, 32).data).join(','); };
    return { a: draw('あ'), i: draw('い') };
  });
  check('uka: Japanese shape names draw as glyphs (あ and い differ), not empty boxes', glyphs.a !== glyphs.i);
  // English aliases of the standard MMD names: the filter finds まばたき by "blink".
  await page.locator('#filter').fill('blink');
  const blink = await page.locator('.shape:visible label').allTextContents();
  check(`uka: the filter finds standard MMD morphs by their English alias, shown beside the name ("blink": ${blink.slice(0, 4).join(', ')})`,
    blink.includes('まばたき \u00b7 blink'));
  await page.locator('#filter').fill('あ');
  await page.locator('input[aria-label="あ"]').first().fill('1');
  await page.waitForTimeout(1500);
  // The WebGL view draws each material in its colour and leaves out the see-through ones (her blush,
  // pallor and irritation marks: alpha 0), which drew as an opaque grey square over her eye.
  const draws = await page.evaluate(() => window.facespace.gl.view.draws.map((d) => d.color));
  const hair = draws.find((c) => c[0] > 0.3 && c[0] < 0.45 && c[2] < 0.1);
  check(`uka: the WebGL view draws her 9 visible materials in their colours, not the 3 see-through ones (${draws.length} drawn)`,
    draws.length === 9 && draws.every((c) => c[3] > 0.02) && hair !== undefined);
  await page.screenshot({ path: `${outDir}/page-uka.png` });
  await page.close();
  const other = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  await other.goto(service + '/#rig=facecap&w=');
  await other.waitForFunction(() => document.querySelectorAll('.shape').length > 10, null, { timeout: 60000 });
  await other.waitForFunction(() => !document.getElementById('credit').hidden, null, { timeout: 15000 }).catch(() => {});
  check('credit: facecap shows the credit its CREDITS.md asks for', (await other.locator('#credit').textContent()).includes('Face Cap model by Bannaflak / Niels Jansson'));
  await other.close();
}
// The creator's tools: presets, undo and redo, a character kept and opened, pictures, layouts.
// A digest of the f32 mesh for `body` (the page's own point when none), fetched from the page.
const meshOf = (page, body) => page.evaluate(async (b) => {
  const point = b || window.facespace.point();
  const r = await fetch(`/v1/rigs/${window.facespace.state.rig}/mesh`,
                        { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify({ ...point, format: 'f32' }) });
  const a = new Uint8Array(await r.arrayBuffer());
  let h = 0;
  for (let i = 0; i < a.length; ++i) h = (h * 31 + a[i]) >>> 0;
  return `${a.length}:${h}`;
}, body);
{
  const context = await browser.newContext({ acceptDownloads: true, viewport: { width: 1280, height: 800 } });
  const page = await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  await page.goto(service + '/#rig=facecap&w=');
  await page.waitForFunction(() => document.querySelectorAll('.shape').length === 52, null, { timeout: 30000 });
  await page.waitForFunction(() => document.querySelectorAll('.thumb.loaded').length === document.querySelectorAll('.thumb').length, null, { timeout: 60000 })
    .catch(() => {});
  const thumbs = await page.evaluate(() => [...document.querySelectorAll('#sliders details')].map((d) =>
    [d.querySelector('h2').textContent, d.querySelectorAll('.thumb.loaded').length, d.querySelectorAll('.thumb').length]));
  const presetThumbs = await page.evaluate(() => [document.querySelectorAll('#presets .thumb.loaded').length, document.querySelectorAll('#presets .preset').length]);
  check(`creator: every group's sliders have their pictures (${thumbs.map((t) => `${t[0]} ${t[1]}/${t[2]}`).join(', ')}) and every preset its own (${presetThumbs.join('/')})`,
    thumbs.length >= 5 && thumbs.every((t) => t[1] === t[2] && t[2] > 0) && presetThumbs[0] === presetThumbs[1] && presetThumbs[1] >= 10);
  await page.locator('#presets .preset[data-name="happy"]').click();
  const happy = await meshOf(page);
  check(`creator: the "happy" preset gives the mesh the route gives for expressions {happy: 1} (${happy})`,
    happy === await meshOf(page, { expressions: { happy: 1 } }) && happy !== await meshOf(page, {}));
  await page.locator('#presets .preset[data-name="happy"]').click();  // Off again.
  const m0 = await meshOf(page);
  const steps = [];
  for (const [name, v] of [['jawOpen', '0.5'], ['mouthSmile_L', '0.7'], ['browInnerUp', '0.3']]) {
    await page.locator(`input[aria-label="${name} value"]`).fill(v);
    await page.locator(`input[aria-label="${name} value"]`).press('Enter');
    await page.locator(`input[aria-label="${name} value"]`).blur();
    steps.push(await meshOf(page));
  }
  for (let i = 0; i < 3; ++i) await page.locator('#undo').click();
  const back = await meshOf(page);
  await page.locator('#redo').click();
  const redone = await meshOf(page);
  await page.keyboard.press('Control+Shift+Z');
  await page.keyboard.press('Control+Shift+Z');
  const again = await meshOf(page);
  check(`creator: three edits then three undos give the first mesh back bit for bit (${back}), redo the first edit, Ctrl+Shift+Z the last`,
    back === m0 && redone === steps[0] && again === steps[2] && new Set(steps).size === 3);
  const [download] = await Promise.all([page.waitForEvent('download'), page.locator('#save').click()]);
  const file = `${outDir}/facecap.character.json`;
  await download.saveAs(file);
  const saved = JSON.parse(fs.readFileSync(file, 'utf8'));
  const fresh = await (await browser.newContext({ viewport: { width: 1280, height: 800 } })).newPage();
  await fresh.goto(service + '/#rig=makehuman&c=');  // Another rig: opening the file brings facecap back.
  await fresh.waitForFunction(() => document.querySelectorAll('.shape').length > 100, null, { timeout: 30000 });
  await fresh.locator('#open').setInputFiles(file);
  await fresh.waitForFunction(() => window.facespace.state.rig === 'facecap' && document.querySelectorAll('.shape').length === 52, null, { timeout: 30000 });
  await fresh.waitForTimeout(300);
  check(`creator: a saved character (${Object.keys(saved.weights).length} weights, rig ${saved.rig}) opened in a fresh page on another rig gives the same mesh`,
    saved.format === 'facespace-character' && await meshOf(fresh) === again);
  const recent = await page.locator('#recent option').count();
  check(`creator: the saved character is kept under Recent (${recent - 1})`, recent >= 2);
  await fresh.close();
  for (const [w, h] of [[1280, 800], [390, 844], [360, 740]]) {
    await page.setViewportSize({ width: w, height: h });
    await page.waitForTimeout(300);
    const size = await page.evaluate(() => [document.documentElement.scrollWidth, window.innerWidth]);
    check(`creator: at ${w} x ${h} nothing overflows sideways (page ${size[0]} px wide in ${size[1]})`, size[0] <= size[1]);
  }
  await page.setViewportSize({ width: 1280, height: 800 });
  check(`creator: no script errors (${errors.slice(0, 2).join('; ')})`, errors.length === 0);
  await context.close();
}
{  // An authored motion whose own keys pass the authored space (Uka's 01_happy, sum up to 4): said on one
   // fixed line, quietly, and nothing below it moves while it plays.
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await page.goto(service + '/#rig=uka&w=');
  await page.waitForFunction(() => document.querySelectorAll('.shape').length > 100, null, { timeout: 60000 });
  await page.locator('#motion-name').selectOption('01_happy');
  const y0 = await page.evaluate(() => document.getElementById('views').getBoundingClientRect().top);
  await page.locator('#motion-play').click();
  const ys = [];
  for (let i = 0; i < 12; ++i) {
    await page.waitForTimeout(250);
    ys.push(await page.evaluate(() => document.getElementById('views').getBoundingClientRect().top));
  }
  const said = await page.locator('#warning').textContent();
  const quiet = await page.locator('#warning').evaluate((el) => el.classList.contains('motion'));
  check(`motion: while 01_happy plays (${said.slice(0, 70)}) the views do not move (${[...new Set([y0, ...ys])].join(', ')} px)`,
    ys.every((y) => y === y0) && /own keys go past the authored space/.test(said) && quiet);
  await page.close();
}
await run('cross-origin', otherPage + '?api=' + encodeURIComponent(service) + '#rig=facecap&w=');
await browser.close();
console.log(`${pass} passed, ${fail} failed`);
process.exit(fail ? 1 : 0);
