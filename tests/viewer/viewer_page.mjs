// Drives hyq-viewer's page in headless Chromium (playwright-core from tools/hyq-viewer/web) and
// checks what it shows against the telemetry recorded by lcm-logger (CSV from hyq-lcm-export).
//
//   node viewer_page.mjs live URL ART_DIR WORK_DIR    (viewer_hil_test.sh: a HIL run meanwhile)
//   node viewer_page.mjs log  URL ART_DIR WORK_DIR    (viewer_log_test.sh: hyq-viewer --log --paused)
//
// live: writes WORK_DIR/ready once the page is connected, then samples the page every 100 ms
// until WORK_DIR/done appears (the shell has then exported WORK_DIR/csv); log: seeks, pauses,
// resumes and changes the speed through the page's own controls. Exit 0 pass, 1 fail.
import fs from 'node:fs';
import path from 'node:path';
import os from 'node:os';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const [mode, url, art, work] = process.argv.slice(2);
const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, '../../tools/hyq-viewer/web/package.json'));
const { chromium } = require('playwright-core');

const failures = [];
const check = (ok, what) => { console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`); if (!ok) failures.push(what); };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// CSV of hyq-lcm-export: header "field (unit)", rows of numbers
function readCsv(file) {
  const lines = fs.readFileSync(file, 'utf8').trim().split('\n');
  const header = lines[0].split(',').map((h) => h.replace(/ \(.*\)$/, ''));
  return lines.slice(1).map((l) => {
    const cells = l.split(',');
    return Object.fromEntries(header.map((h, i) => [h, Number(cells[i])]));
  });
}

const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'hyq-viewer-chromium.'));
const context = await chromium.launchPersistentContext(profile, {
  executablePath: '/usr/bin/chromium',
  headless: true,
  viewport: { width: 1280, height: 720 },
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync',
    '--enable-unsafe-swiftshader'],  // WebGL on the CPU (SwiftShader) without a GPU
});
const page = context.pages()[0] || await context.newPage();
const errors = [];
page.on('pageerror', (e) => errors.push(e.message));
// what the page shows, read from its DOM and its scene (window.hyqViewer)
const SUMMARY = () => {
  const v = window.hyqViewer;
  const f = v.lastFrame || {};
  const c = document.getElementById('contacts');
  return {
    connected: v.connected, frames: v.frames, webgl: v.webgl, trunk: v.trunkPosition(), feet: v.footPositions(),
    ghost: v.ghostVisible && document.getElementById('truth').dataset.on === '1',
    shownCount: Number(c.dataset.count), shownCycle: Number(c.dataset.cycle),
    mode: document.getElementById('mode').textContent,
    jointCycle: f.joint ? f.joint.cycle : -1,
    playback: f.playback || null, ignored: f.controls_ignored, events: (v.events || []).length,
    eventRows: document.getElementById('events').children.length,
    velocityCycle: Number(document.getElementById('velocity').dataset.cycle),
    velocitySigma: Number(document.getElementById('velocity').dataset.sigma),
  };
};
const state = () => page.evaluate(`(${SUMMARY})()`);

try {
  await page.goto(url);
  await page.waitForFunction(() => window.hyqViewer && window.hyqViewer.connected && window.hyqViewer.frames > 2
    && window.hyqViewer.robotLoaded, null, { timeout: 20000 });
  const s0 = await state();
  check(s0.connected, 'the page connects to the bridge');
  check(s0.webgl, 'WebGL is available (SwiftShader)');
  if (mode === 'live') await live(); else await log();
} catch (e) {
  check(false, `exception: ${e.message}`);
}
check(errors.length === 0, `no page errors${errors.length ? ': ' + errors.join('; ') : ''}`);
await context.close();
fs.rmSync(profile, { recursive: true, force: true });
console.log(failures.length ? `${failures.length} check(s) failed` : 'all checks passed');
process.exit(failures.length ? 1 : 0);

async function live() {
  // the page is read-only: a command from it is ignored and the stream goes on
  await page.evaluate(() => window.hyqViewer.send({ cmd: 'pause' }));
  await page.screenshot({ path: path.join(art, 'viewer_live.png') });  // the first one is slow (~2 s)
  fs.writeFileSync(path.join(work, 'ready'), '');
  // every frame the page draws is summarised by the page itself (a hook after each frame)
  await page.evaluate(`window.__samples = []; window.hyqViewer.onFrame = () => window.__samples.push((${SUMMARY})())`);
  let shot = false;
  const t0 = Date.now();
  while (!fs.existsSync(path.join(work, 'done')) && Date.now() - t0 < 240000) {
    // the screenshot while trotting: active, truth on, some distance walked
    const s = await page.evaluate(() => {
      const a = window.__samples.filter((x) => x.mode === 'active');
      return a.length ? { n: a.length, first: a[0], last: a[a.length - 1] } : null;
    });
    if (process.env.HYQ_VIEWER_DEBUG) console.log(Date.now() - t0, s && s.n, s && s.last.mode);
    if (!shot && s && s.n > 10 && s.last.ghost && s.last.mode === 'active'
        && Math.hypot(s.last.trunk[0] - s.first.trunk[0], s.last.trunk[1] - s.first.trunk[1]) > 0.02) {
      const w = Date.now();
      await page.screenshot({ path: path.join(art, 'viewer_live.png') });
      const after = await state();
      console.log(`screenshot in ${Date.now() - w} ms, mode then '${after.mode}'`);
      shot = after.mode === 'active';
    }
    await sleep(200);
  }
  const last = await state();
  const samples = await page.evaluate(() => window.__samples);
  check(shot, 'screenshot taken while trotting');
  if (!shot) await page.screenshot({ path: path.join(art, 'viewer_live.png') });
  fs.writeFileSync(path.join(art, 'viewer_live_samples.json'), JSON.stringify(samples));
  const active = samples.filter((s) => s.mode === 'active');
  console.log(`${samples.length} samples, ${active.length} while ACTIVE, ${last.frames} frames`);
  check(active.length >= 20, `the page showed mode 'active' (${active.length} samples)`);
  check(last.ignored >= 1, `a command sent by the page was ignored (controls_ignored ${last.ignored})`);
  // the robot's pose changes as the trot proceeds: the drawn trunk moves, the drawn feet move
  const span = (f) => Math.max(...active.map(f)) - Math.min(...active.map(f));
  const trunkMove = Math.max(span((s) => s.trunk[0]), span((s) => s.trunk[1]));
  const footMove = Math.max(...[0, 1, 2, 3].map((i) => span((s) => s.feet[i][2])));
  check(trunkMove > 0.02, `the drawn trunk moves while trotting (${trunkMove.toFixed(3)} m)`);
  check(footMove > 0.02, `the drawn feet lift and land (max height span ${footMove.toFixed(3)} m)`);
  check(new Set(active.map((s) => s.jointCycle)).size >= 5, 'the joint state advances');
  // the contact count shown equals the telemetry of the same cycle, as lcm-logger recorded it
  const rows = readCsv(path.join(work, 'csv', 'HYQ_CONTACT.csv'));
  const byCycle = new Map(rows.map((r) => [r.cycle,
    ['lf', 'rf', 'lh', 'rh'].reduce((n, f) => n + (r[`stance_estimated.${f}`] ? 1 : 0), 0)]));
  let compared = 0, mismatched = 0;
  const counts = new Set();
  for (const s of samples) {
    if (s.shownCycle < 0 || !byCycle.has(s.shownCycle)) continue;
    compared += 1;
    counts.add(s.shownCount);
    if (byCycle.get(s.shownCycle) !== s.shownCount) mismatched += 1;
  }
  check(compared >= 20 && mismatched === 0,
    `stance count shown = HYQ_CONTACT's stance_estimated of that cycle (${compared} compared, ${mismatched} differ)`);
  check(counts.size >= 2, `the stance count changes as the feet step (${[...counts].sort().join(', ')})`);
  // the velocity's uncertainty shown = HYQ_BASE_STATE's standard deviation of that cycle
  const base = new Map(readCsv(path.join(work, 'csv', 'HYQ_BASE_STATE.csv')).map((r) => [r.cycle,
    Math.max(r['velocity_std_m_s.x'], r['velocity_std_m_s.y'])]));
  let sigmas = 0, sigmaOff = 0;
  for (const s of samples) {
    if (s.velocityCycle < 0 || !base.has(s.velocityCycle)) continue;
    sigmas += 1;
    const want = base.get(s.velocityCycle);
    if (Math.abs(want - s.velocitySigma) > 1e-4 * Math.abs(want) || !(s.velocitySigma > 0)) sigmaOff += 1;
  }
  check(sigmas >= 20 && sigmaOff === 0,
    `velocity σ shown = HYQ_BASE_STATE's velocity_std_m_s of that cycle (${sigmas} compared, ${sigmaOff} differ)`);
  const ghost = samples.filter((s) => s.ghost).length;
  check(ghost >= 3, `the truth ghost appears (${ghost} samples)`);
  check(last.events >= 1 && last.eventRows >= 1, `events listed (${last.events} received, ${last.eventRows} shown)`);
}

async function log() {
  // the expected joint-state cycle at log time t: the last one lcm-logger received by then
  const channels = ['HYQ_JOINT_STATE', 'HYQ_BASE_STATE', 'HYQ_CONTACT', 'HYQ_FRICTION', 'HYQ_TIMING', 'HYQ_EVENT',
    'HYQ_JOINT_TORQUE', 'HYQ_SIM_TRUTH'];
  let first = Infinity;
  for (const ch of channels) {
    const f = path.join(work, 'csv', `${ch}.csv`);
    if (fs.existsSync(f)) for (const r of readCsv(f)) first = Math.min(first, r.log_utime);
  }
  const joints = readCsv(path.join(work, 'csv', 'HYQ_JOINT_STATE.csv'));
  const expectedCycle = (t) => {
    let c = -1;
    for (const r of joints) if (r.log_utime - first <= Math.round(t * 1e6)) c = r.cycle;
    return c;
  };
  const s0 = await state();
  check(s0.playback && s0.playback.paused && s0.playback.t_s === 0, 'starts paused at 0 s (--paused)');
  await sleep(500);
  const s1 = await state();
  check(s1.playback.t_s === 0 && s1.frames > s0.frames, 'paused: frames keep coming, time stands still');

  // seek through the page's slider
  const seek = async (t) => {
    await page.evaluate((x) => {
      const el = document.getElementById('seek');
      el.value = String(x);
      el.dispatchEvent(new Event('change'));
    }, t);
    await page.waitForFunction((x) => {
      const p = window.hyqViewer.lastFrame && window.hyqViewer.lastFrame.playback;
      return p && Math.abs(p.t_s - x) < 1e-3;
    }, t, { timeout: 5000 }).catch(async () => {
      throw new Error(`seek to ${t} s: the page shows ${JSON.stringify((await state()).playback)}`);
    });
    await sleep(200);
    return state();
  };
  const duration = s0.playback.duration_s;
  const tA = Math.min(1.0, duration / 2), tB = Math.max(duration - 0.3, tA + 0.2);
  const a = await seek(tA);
  check(a.jointCycle === expectedCycle(tA), `seek to ${tA} s shows cycle ${a.jointCycle} (log: ${expectedCycle(tA)})`);
  const b = await seek(tB);
  check(b.jointCycle === expectedCycle(tB), `seek to ${tB.toFixed(2)} s shows cycle ${b.jointCycle} (log: ${expectedCycle(tB)})`);
  const moved = Math.hypot(...[0, 1, 2].map((i) => a.trunk[i] - b.trunk[i]));
  check(moved > 0.01, `the robot's pose differs between ${tA} s and ${tB.toFixed(2)} s (${moved.toFixed(3)} m)`);
  const a2 = await seek(tA);
  check(a2.jointCycle === a.jointCycle && Math.hypot(...[0, 1, 2].map((i) => a.trunk[i] - a2.trunk[i])) < 1e-9,
    'seeking back shows the same pose again');
  await page.screenshot({ path: path.join(art, 'viewer_log.png') });

  // speed 0.5 and resume through the page's controls: log time advances at half the wall time
  await page.selectOption('#speed', '0.5');
  await page.click('#play');
  await page.waitForFunction(() => !window.hyqViewer.lastFrame.playback.paused, null, { timeout: 5000 });
  const r0 = await state();
  const w0 = Date.now();
  await sleep(800);
  const r1 = await state();
  const rate = (r1.playback.t_s - r0.playback.t_s) / ((Date.now() - w0) / 1000);
  check(r1.playback.speed === 0.5 && rate > 0.3 && rate < 0.7, `speed 0.5: log time advanced ${rate.toFixed(2)} s per s`);
  check(r1.jointCycle > r0.jointCycle, 'resumed: the joint state advances');
  await page.click('#play');
  await page.waitForFunction(() => window.hyqViewer.lastFrame.playback.paused, null, { timeout: 5000 });
  const p0 = await state();
  await sleep(400);
  const p1 = await state();
  check(p1.playback.t_s === p0.playback.t_s, 'paused again: time stands still');

  // the marks drawn for a frame made up by hand: stance lf, rf; rf slipping; lh slipping in swing
  const marks = await page.evaluate(() => {
    const v = window.hyqViewer;
    const f = JSON.parse(JSON.stringify(v.lastFrame));
    f.events = [];
    f.contact.stance_estimated = [true, true, false, false];
    f.contact.stance_count = 2;
    f.contact.mu = [0.5, 0.9, 0.3, 0.3];
    f.contact.contact_force_N = [[10, 0, 200], [0, 0, 150], [0, 0, 0], [0, 0, 0]];
    f.friction = { slipping: [false, true, true, false] };
    v.showFrame(f);
    return { marks: v.contactMarks(), slips: document.getElementById('slips').textContent,
      shown: document.getElementById('contacts').textContent };
  });
  const m = marks.marks;
  check(m[0].arrow && m[1].arrow && !m[2].arrow && !m[3].arrow, 'force arrows on the stance feet only');
  check(m[0].pyramid && Math.abs(m[0].pyramid_scale - 0.5) < 1e-9 && Math.abs(m[1].pyramid_scale - 0.9) < 1e-9
    && !m[2].pyramid, `friction pyramids on the stance feet, scaled by mu (${m[0].pyramid_scale}, ${m[1].pyramid_scale})`);
  check(!m[0].slip && m[1].slip && m[2].slip && !m[3].slip && marks.slips === 'rf lh',
    `slip markers on rf and lh ('${marks.slips}')`);
  check(marks.shown.startsWith('2/4 (lf rf)'), `stance shown '${marks.shown}'`);

  // garbage from the browser is ignored, the bridge goes on
  await page.evaluate(() => {
    const v = window.hyqViewer;
    v.send({ cmd: 'seek', t_s: 'soon' });
    v.send({ cmd: 'speed', speed: 1e9 });
    v.send({ cmd: 'drive', v: 1 });
    v.send([1, 2, 3]);
    const w = new WebSocket(`ws://${location.host}/ws`);  // not JSON at all, and binary
    w.onopen = () => { w.send('garbage {'); w.send(new Uint8Array([0, 255, 7])); };
  });
  await sleep(500);
  const g = await state();
  check(g.ignored >= 4 && g.connected && g.frames > p1.frames && g.playback.t_s === p1.playback.t_s,
    `bad controls ignored (${g.ignored}), still streaming, time unchanged`);
}
