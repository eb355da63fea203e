// hyq-viewer's page: the robot in 3D (estimated, and hyq-sim's truth as a ghost), contacts,
// friction pyramids, slips, mode, events and plots, from the frames hyq-viewer sends on /ws.
// Read-only: the only messages sent back are playback controls, which the bridge honours in
// --log mode and ignores live.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';
import './style.css';
import { parseUrdf, buildRobot, setJoints, setBase, FEET } from './urdf.js';

const FOOT_RADIUS_M = 0.02175;
const FORCE_SCALE_M_PER_N = 0.001;
const PYRAMID_HEIGHT_M = 0.15;
const PLOT_WINDOW_S = 10;
const $ = (id) => document.getElementById(id);

// state exposed for tests and the console (window.hyqViewer)
const viewer = { connected: false, frames: 0, lastFrame: null, stanceShown: -1, ghostVisible: false, webgl: false };
window.hyqViewer = viewer;

// --- 3D scene, z up ---
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x20242a);
const camera = new THREE.PerspectiveCamera(45, 1, 0.05, 100);
camera.up.set(0, 0, 1);
camera.position.set(1.6, -2.4, 1.4);
let renderer = null;
try {
  renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  $('view').appendChild(renderer.domElement);
  viewer.webgl = true;
} catch (e) {
  $('view').textContent = `WebGL unavailable: ${e.message}`;
}
const controls = renderer ? new OrbitControls(camera, renderer.domElement) : null;
if (controls) controls.target.set(0, 0, 0.5);
scene.add(new THREE.HemisphereLight(0xffffff, 0x445566, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(2, -3, 5);
scene.add(sun);
const grid = new THREE.GridHelper(20, 40, 0x666666, 0x3a3f46);
grid.rotation.x = Math.PI / 2;
scene.add(grid);
scene.add(new THREE.AxesHelper(0.3));

function resize() {
  const w = window.innerWidth, h = window.innerHeight;
  camera.aspect = w / h;
  // the plots cover the right: centre the robot in what is left of the window
  if (w > 900) camera.setViewOffset(w, h, 220, 0, w, h);
  else camera.clearViewOffset();
  camera.updateProjectionMatrix();
  if (renderer) renderer.setSize(w, h);
}
window.addEventListener('resize', () => { resize(); dirty = true; });
resize();

let robot = null, ghost = null;
const feet = FEET.map(() => {
  const arrow = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 0.1, 0x3fdc5a, 0.05, 0.03);
  // friction pyramid for μ = 1, apex at the contact point, opening up; scaled by μ in x and y
  const geom = new THREE.ConeGeometry(Math.SQRT2 * PYRAMID_HEIGHT_M, PYRAMID_HEIGHT_M, 4, 1, true)
    .rotateX(Math.PI).translate(0, PYRAMID_HEIGHT_M / 2, 0).rotateX(Math.PI / 2).rotateZ(Math.PI / 4);
  const pyramid = new THREE.Group();
  pyramid.add(new THREE.Mesh(geom, new THREE.MeshBasicMaterial({ color: 0xf2cc60, transparent: true, opacity: 0.15,
    side: THREE.DoubleSide, depthWrite: false })));
  pyramid.add(new THREE.LineSegments(new THREE.EdgesGeometry(geom), new THREE.LineBasicMaterial({ color: 0xf2cc60 })));
  const slip = new THREE.Mesh(new THREE.TorusGeometry(0.06, 0.012, 8, 24), new THREE.MeshBasicMaterial({ color: 0xff3b30 }));
  for (const o of [arrow, pyramid, slip]) { o.visible = false; scene.add(o); }
  return { arrow, pyramid, slip };
});

fetch('hyq.urdf').then((r) => {
  if (!r.ok) throw new Error(`hyq.urdf: HTTP ${r.status}`);
  return r.text();
}).then((text) => {
  const urdf = parseUrdf(text);
  robot = buildRobot(urdf, new THREE.MeshStandardMaterial({ color: 0xb8bcc4, metalness: 0.2, roughness: 0.6 }));
  // the truth as a cyan wireframe: visible even where it coincides with the estimate
  ghost = buildRobot(urdf, new THREE.MeshBasicMaterial({ color: 0x40d0ff, wireframe: true, transparent: true,
    opacity: 0.55 }));
  ghost.root.visible = false;
  scene.add(robot.root, ghost.root);
  robot.root.position.set(0, 0, 0.6);
  viewer.robotLoaded = true;
}).catch((e) => { $('status').textContent = `robot model: ${e.message}`; });

viewer.trunkPosition = () => (robot ? robot.root.position.toArray() : null);
viewer.footPositions = () => (robot ? FEET.map((f) => robot.links[`${f}_foot`].getWorldPosition(new THREE.Vector3()).toArray()) : null);

viewer.contactMarks = () => feet.map((g) => ({ arrow: g.arrow.visible, pyramid: g.pyramid.visible,
  pyramid_scale: g.pyramid.scale.x, slip: g.slip.visible }));

// --- plots (uPlot), last PLOT_WINDOW_S seconds of servo time ---
const JOINT_COLORS = ['#e6194b', '#f58231', '#ffe119', '#3cb44b', '#42d4f4', '#4363d8', '#911eb4', '#f032e6',
  '#a9a9a9', '#fabed4', '#aaffc3', '#dcbeff'];
const JN = FEET.flatMap((l) => ['haa', 'hfe', 'kfe'].map((k) => `${l}_${k}`));
function makePlot(title, series, height) {
  const data = [[], ...series.map(() => [])];
  const plot = new uPlot({ title, width: 430, height, legend: { show: series.length <= 3 },
    scales: { x: { time: false } },
    axes: [{ stroke: '#bbb', grid: { stroke: '#333' } }, { stroke: '#bbb', grid: { stroke: '#333' }, size: 50 }],
    series: [{ label: 't (s)' }, ...series] }, data, $('plots'));
  return { plot, data };
}
const plots = {
  tracking: makePlot('tracking error (rad)', [{ label: '‖q_ref − q‖ rad', stroke: '#7ddc7d' }], 130),
  torque: makePlot('commanded joint torque (N·m)', JN.map((n, i) => ({ label: n, stroke: JOINT_COLORS[i], width: 1 })), 170),
  qp: makePlot('QP solve time (µs)', [{ label: 'stage1+stage2', stroke: '#42d4f4' },
    { label: 'max since last frame', stroke: '#f58231' }], 130),
  // the estimate with its ±2σ band (the EKF's own uncertainty) and, with hyq-sim --lcm-truth, the truth
  velocity: makePlot('base velocity x (m/s), estimate ± 2σ', [{ label: 'estimate', stroke: '#f2cc60' },
    { label: '−2σ', stroke: '#8a7a40', dash: [4, 4], width: 1 }, { label: '+2σ', stroke: '#8a7a40', dash: [4, 4], width: 1 },
    { label: 'truth', stroke: '#40d0ff', width: 1 }], 150),
};
let lastPlotT = -Infinity;
function plotFrame(f) {
  if (!f.joint) return;
  const t = f.joint.utime * 1e-6;
  if (t < lastPlotT) for (const p of Object.values(plots)) p.data.forEach((a) => { a.length = 0; });  // a seek back
  if (t === lastPlotT) return;
  lastPlotT = t;
  const push = (p, values) => {
    p.data[0].push(t);
    values.forEach((v, i) => p.data[i + 1].push(Number.isFinite(v) ? v : null));
    while (p.data[0].length && p.data[0][0] < t - PLOT_WINDOW_S) p.data.forEach((a) => a.shift());
    p.plot.setData(p.data);
  };
  push(plots.tracking, [f.joint.tracking_error_rad]);
  push(plots.torque, f.torque ? f.torque.tau_command_Nm : JN.map(() => null));
  push(plots.qp, f.contact ? [f.contact.qp_solve_us, f.qp_solve_max_us] : [null, null]);
  const b = f.base;
  const sx = b && b.velocity_std_m_s ? b.velocity_std_m_s[0] : null;
  push(plots.velocity, b ? [b.velocity_m_s[0], sx === null ? null : b.velocity_m_s[0] - 2 * sx,
    sx === null ? null : b.velocity_m_s[0] + 2 * sx, f.truth ? f.truth.velocity_m_s[0] : null] : [null, null, null, null]);
}

// --- frames ---
const events = [];
function showFrame(f) {
  viewer.frames += 1;
  dirty = true;
  viewer.lastFrame = f;
  $('source').textContent = f.source === 'log' ? '· log playback' : '· live';
  $('messages').textContent = f.stats.messages;
  $('undecodable').textContent = f.stats.undecodable;
  if (f.joint) {
    const m = $('mode');
    m.textContent = f.joint.mode_name;
    m.className = f.joint.mode_name === 'active' ? 'ok' : (f.joint.mode_name === 'fault' ? 'bad' : 'warn');
    if (robot) setJoints(robot, f.joint.q_rad);
  }
  if (f.torque) $('controller').textContent = ['pid', 'noslip', 'stage1', 'two_stage'][f.torque.controller] ?? f.torque.controller;
  if (f.base) {
    if (robot) setBase(robot, f.base.position_m, f.base.orientation_wxyz);
    $('base').textContent = f.base.position_m.map((x) => x.toFixed(2)).join(', ') + ' m';
    // horizontal speed ± 2σ (the filter's standard deviation, the larger horizontal one)
    const vel = $('velocity');
    const sd = f.base.velocity_std_m_s ? Math.max(f.base.velocity_std_m_s[0], f.base.velocity_std_m_s[1]) : NaN;
    vel.textContent = `${f.base.velocity_m_s.slice(0, 2).map((x) => x.toFixed(3)).join(', ')} m/s`
      + (Number.isFinite(sd) ? ` ± ${(2 * sd * 100).toFixed(1)} cm/s (2σ)` : '');
    vel.dataset.cycle = String(f.base.cycle);
    vel.dataset.sigma = String(Number.isFinite(sd) ? sd : -1);
  }
  if (f.truth && ghost) {
    ghost.root.visible = true;
    setJoints(ghost, f.truth.q_rad);
    setBase(ghost, f.truth.position_m, f.truth.orientation_wxyz);
  }
  viewer.ghostVisible = Boolean(ghost && ghost.root.visible);
  $('truth').textContent = viewer.ghostVisible ? `on (sim t ${f.truth.sim_time_s.toFixed(2)} s)` : 'off';
  $('truth').dataset.on = viewer.ghostVisible ? '1' : '0';
  if (robot) robot.root.updateMatrixWorld(true);
  // contacts: stance count, force arrows, friction pyramids, slips
  const c = f.contact;
  const slipping = f.friction ? f.friction.slipping : [false, false, false, false];
  if (c) {
    viewer.stanceShown = c.stance_count;
    $('contacts').textContent = `${c.stance_count}/4 (${FEET.filter((_, i) => c.stance_estimated[i]).join(' ') || 'none'})`;
    $('contacts').dataset.count = String(c.stance_count);
    $('contacts').dataset.cycle = String(c.cycle);
  }
  $('slips').textContent = FEET.filter((_, i) => slipping[i]).join(' ') || 'none';
  if (robot) {
    FEET.forEach((name, i) => {
      const p = robot.links[`${name}_foot`].getWorldPosition(new THREE.Vector3());
      p.z -= FOOT_RADIUS_M;
      const g = feet[i];
      const stance = Boolean(c && c.stance_estimated[i]);
      const fv = c ? new THREE.Vector3(...c.contact_force_N[i]) : new THREE.Vector3();
      const fN = fv.length();
      g.arrow.visible = stance && fN > 1;
      if (g.arrow.visible) {
        g.arrow.position.copy(p);
        g.arrow.setDirection(fv.clone().normalize());
        g.arrow.setLength(Math.max(fN * FORCE_SCALE_M_PER_N, 0.06), 0.05, 0.03);
      }
      g.pyramid.visible = stance && Number.isFinite(c.mu[i]);
      if (g.pyramid.visible) {
        g.pyramid.position.copy(p);
        g.pyramid.scale.set(Math.max(c.mu[i], 0.01), Math.max(c.mu[i], 0.01), 1);
      }
      g.slip.visible = Boolean(slipping[i]);
      if (g.slip.visible) g.slip.position.copy(p);
    });
  }
  // events: all of them into viewer.events; the list shows the bridge's last 12, newest first
  for (const e of f.events) events.unshift(e);
  events.length = Math.min(events.length, 100);
  viewer.events = events;
  const list = $('events');
  list.replaceChildren(...(f.recent_events || []).slice().reverse().map((e) => {
    const li = document.createElement('li');
    li.textContent = `#${e.cycle} ${e.from_name}→${e.to_name} ${e.reason}${e.detail ? ': ' + e.detail : ''}`;
    li.className = e.to_name === 'fault' || e.to_name === 'damping' ? 'bad' : '';
    return li;
  }));
  if (f.playback) showPlayback(f.playback);
  plotFrame(f);
}

viewer.showFrame = showFrame;  // for tests: draw a frame made up by hand

// --- playback controls (log mode) ---
let seeking = false;
function showPlayback(p) {
  $('playback').hidden = false;
  $('play').textContent = p.paused ? 'play' : 'pause';
  $('seek').max = String(p.duration_s);
  if (!seeking) $('seek').value = String(p.t_s);
  $('ptime').textContent = `${p.t_s.toFixed(2)} / ${p.duration_s.toFixed(2)} s`;
  $('ptime').dataset.t = String(p.t_s);
  viewer.playback = p;
}
const send = (msg) => { if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(msg)); };
viewer.send = send;
$('play').onclick = () => send({ cmd: viewer.playback && viewer.playback.paused ? 'resume' : 'pause' });
$('seek').oninput = () => { seeking = true; };
$('seek').onchange = () => { seeking = false; send({ cmd: 'seek', t_s: Number($('seek').value) }); };
$('speed').onchange = () => send({ cmd: 'speed', speed: Number($('speed').value) });

// --- WebSocket, reconnecting ---
let ws = null;
function connect() {
  ws = new WebSocket(`ws://${location.host}/ws`);
  ws.onopen = () => { viewer.connected = true; $('status').textContent = 'connected'; $('status').className = 'ok'; };
  ws.onclose = () => {
    viewer.connected = false;
    $('status').textContent = 'disconnected, retrying…';
    $('status').className = 'bad';
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => {
    let f;
    try { f = JSON.parse(ev.data); } catch { return; }
    if (f && f.type === 'frame') {
      showFrame(f);
      if (viewer.onFrame) viewer.onFrame(f);  // a test's or the console's hook
    }
  };
}
connect();

// --- render loop: on demand (a new frame, the camera following or moved by the user) ---
const followed = new THREE.Vector3(0, 0, 0.5);
let dirty = true;
if (controls) controls.addEventListener('change', () => { dirty = true; });
viewer.redraw = () => { dirty = true; };
function animate() {
  requestAnimationFrame(animate);
  if (!renderer) return;
  if (robot) {
    const p = robot.root.position;
    const target = new THREE.Vector3(p.x, p.y, Math.max(p.z, 0.2));
    const delta = target.clone().sub(followed).multiplyScalar(0.2);
    if (delta.lengthSq() > 1e-10) {
      followed.add(delta);
      controls.target.add(delta);
      camera.position.add(delta);
      dirty = true;
    }
  }
  controls.update();
  if (!dirty) return;
  dirty = false;
  renderer.render(scene, camera);
}
animate();
