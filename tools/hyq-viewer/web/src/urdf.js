// The robot drawn from the project's URDF (config/robots/hyq.urdf, served by hyq-viewer as
// /hyq.urdf): its primitive collision shapes, its joint origins (xyz, rpy) and axes.
import * as THREE from 'three';

const num = (s, n) => (s || '').trim().split(/\s+/).filter(Boolean).map(Number).concat([0, 0, 0]).slice(0, n);

function origin(el) {
  const o = el && el.querySelector(':scope > origin');
  return { xyz: num(o && o.getAttribute('xyz'), 3), rpy: num(o && o.getAttribute('rpy'), 3) };
}

// URDF rpy is a rotation about fixed x, then y, then z: R = Rz(y) Ry(p) Rx(r), three's 'ZYX'
function place(obj, o) {
  obj.position.set(...o.xyz);
  obj.rotation.set(o.rpy[0], o.rpy[1], o.rpy[2], 'ZYX');
}

/** {links: {name: [shape]}, joints: [{name, type, parent, child, origin, axis}]} */
export function parseUrdf(text) {
  const doc = new DOMParser().parseFromString(text, 'application/xml');
  if (doc.querySelector('parsererror')) throw new Error('hyq.urdf: not well-formed XML');
  const links = {};
  for (const l of doc.querySelectorAll('robot > link')) {
    const shapes = [];
    for (const c of l.querySelectorAll(':scope > collision, :scope > visual')) {
      const g = c.querySelector('geometry > *');
      if (!g) continue;
      shapes.push({ type: g.tagName, origin: origin(c), size: num(g.getAttribute('size'), 3),
        radius: Number(g.getAttribute('radius') || 0), length: Number(g.getAttribute('length') || 0) });
    }
    links[l.getAttribute('name')] = shapes;
  }
  const joints = [];
  for (const j of doc.querySelectorAll('robot > joint')) {
    joints.push({ name: j.getAttribute('name'), type: j.getAttribute('type'),
      parent: j.querySelector('parent').getAttribute('link'), child: j.querySelector('child').getAttribute('link'),
      origin: origin(j), axis: num(j.querySelector('axis') && j.querySelector('axis').getAttribute('xyz') || '1 0 0', 3) });
  }
  return { links, joints };
}

function shapeMesh(s, material) {
  let geom;
  if (s.type === 'box') geom = new THREE.BoxGeometry(...s.size);
  else if (s.type === 'cylinder') geom = new THREE.CylinderGeometry(s.radius, s.radius, s.length, 20).rotateX(Math.PI / 2);
  else if (s.type === 'sphere') geom = new THREE.SphereGeometry(s.radius, 16, 12);
  else return null;  // meshes are not drawn (the project's URDF has none)
  const m = new THREE.Mesh(geom, material);
  place(m, s.origin);
  return m;
}

/**
 * The kinematic tree below `rootLink` as three.js groups. Each revolute joint is an origin group
 * (fixed) holding a motion group rotated about the joint axis by q. Returns {root, joints, links}.
 */
export function buildRobot(urdf, material, rootLink = 'trunk') {
  const joints = {}, links = {};
  const jointMarker = new THREE.SphereGeometry(0.035, 12, 8);
  const makeLink = (name) => {
    const g = new THREE.Group();
    g.name = name;
    links[name] = g;
    for (const s of urdf.links[name] || []) {
      const m = shapeMesh(s, material);
      if (m) g.add(m);
    }
    for (const j of urdf.joints.filter((j) => j.parent === name && j.type !== 'floating')) {
      const o = new THREE.Group();
      place(o, j.origin);
      const motion = new THREE.Group();
      o.add(motion);
      if (j.type === 'revolute' || j.type === 'continuous') {
        joints[j.name] = { motion, axis: new THREE.Vector3(...j.axis).normalize() };
        motion.add(new THREE.Mesh(jointMarker, material));
      }
      motion.add(makeLink(j.child));
      g.add(o);
    }
    return g;
  };
  return { root: makeLink(rootLink), joints, links };
}

export const JOINT_NAMES = ['lf', 'rf', 'lh', 'rh'].flatMap((l) => ['haa', 'hfe', 'kfe'].map((k) => `${l}_${k}_joint`));
export const FEET = ['lf', 'rf', 'lh', 'rh'];

/** Sets the 12 joint angles (rad, project order lf, rf, lh, rh x haa, hfe, kfe). */
export function setJoints(robot, q) {
  JOINT_NAMES.forEach((name, i) => {
    const j = robot.joints[name];
    if (j && Number.isFinite(q[i])) j.motion.quaternion.setFromAxisAngle(j.axis, q[i]);
  });
}

/** Base pose: position (m) and orientation (w, x, y, z) in W. */
export function setBase(robot, p, wxyz) {
  if (p.every(Number.isFinite)) robot.root.position.set(p[0], p[1], p[2]);
  if (wxyz.every(Number.isFinite)) robot.root.quaternion.set(wxyz[1], wxyz[2], wxyz[3], wxyz[0]).normalize();
}
