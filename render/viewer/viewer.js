// qean view: dances drawn in 3-D beside each other, driven by the music's clock (SPEC-free UI code).
// Built into render/assets/viewer.bundle.js by tools/build_viewer.sh (esbuild; three.js is MIT, see the
// bundle's header). The page embeds the bundle, the dances (joint positions, 60 fps) and the music.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

const data = JSON.parse(document.getElementById('qean-data').textContent);
const fps = data.fps;
const palette = [0x4c8bf5, 0xf5a142, 0x3fbf6f, 0xd9534f, 0x9b6fd9, 0x2bb5b8, 0xc7c739, 0xe377c2];
const status = document.getElementById('status');
const title = (s) => { document.title = 'qean view: ' + s; };
window.addEventListener('error', (e) => title('error ' + e.message));

function decode(b64) {
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  return new Float32Array(bytes.buffer);
}
const dances = data.dances.map((d, i) => ({ ...d, joints: decode(d.joints), color: palette[i % palette.length] }));
const frames = Math.max(...dances.map((d) => d.frames));
const danceSeconds = Math.min(...dances.map((d) => d.frames)) / fps;

// Scene: floor grid, light, one figure per dance, side by side along x.
const view = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f4f0);
scene.add(new THREE.HemisphereLight(0xffffff, 0x8888aa, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(2, 5, 3);
scene.add(sun);
const spacing = data.overlay ? 0 : 1.6;
const width = spacing * (dances.length - 1);
scene.add(new THREE.GridHelper(Math.max(8, width + 6), Math.round(Math.max(8, width + 6) / 0.5), 0x999999, 0xcccccc));
const camera = new THREE.PerspectiveCamera(40, 1, 0.05, 100);
camera.position.set(0, 1.6, 4.5 + width * 0.6);
const controls = new OrbitControls(camera, renderer.domElement);
controls.target.set(0, 0.9, 0);
controls.update();

const up = new THREE.Vector3(0, 1, 0);
const figures = dances.map((d, i) => {
  const material = new THREE.MeshStandardMaterial({ color: d.color, roughness: 0.7 });
  const group = new THREE.Group();
  scene.add(group);
  const bones = [];
  for (let j = 1; j < 24; j++) {
    const r = [3, 6, 9].includes(j) ? 0.05 : 0.025;
    const m = new THREE.Mesh(new THREE.CylinderGeometry(r, r, 1, 10), material);
    group.add(m);
    bones.push([j, data.parents[j], m]);
  }
  const head = new THREE.Mesh(new THREE.SphereGeometry(0.1, 16, 12), material);
  group.add(head);
  // Centre each dance on its first root position, put its lowest joint on the floor, place it in its column.
  const j0 = d.joints;
  let floor = Infinity;
  for (let k = 1; k < j0.length; k += 3) floor = Math.min(floor, j0[k]);
  const offset = new THREE.Vector3(-j0[0] + (i - (dances.length - 1) / 2) * spacing, -floor, -j0[2]);
  return { d, bones, head, offset };
});

const a = new THREE.Vector3();
const b = new THREE.Vector3();
function pose(frame) {
  for (const f of figures) {
    const k = Math.min(frame, f.d.frames - 1) * 72;
    const p = (j, v) => v.set(f.d.joints[k + 3 * j], f.d.joints[k + 3 * j + 1], f.d.joints[k + 3 * j + 2]).add(f.offset);
    for (const [j, parent, mesh] of f.bones) {
      p(parent, a);
      p(j, b);
      const dir = b.clone().sub(a);
      const len = Math.max(dir.length(), 1e-6);
      mesh.position.copy(a).addScaledVector(dir, 0.5);
      mesh.quaternion.setFromUnitVectors(up, dir.divideScalar(len));
      mesh.scale.set(1, len, 1);
    }
    p(15, a);
    f.head.position.set(a.x, a.y + 0.08, a.z);
  }
}

// Clock: the audio element when there is music, else the page's own.
const audio = document.getElementById('music');
let duration = danceSeconds;
let start = performance.now();
let paused = true;
let speed = 1;
let offline = 0;
const now = () => (audio ? audio.currentTime : paused ? offline : offline + ((performance.now() - start) / 1000) * speed);
function seek(t) {
  t = Math.max(0, Math.min(t, duration));
  if (audio) audio.currentTime = t;
  offline = t;
  start = performance.now();
}
function play(on) {
  if (on && now() >= duration - 1e-3) seek(0);
  paused = !on;
  offline = now();
  start = performance.now();
  if (audio) (on ? audio.play() : audio.pause());
  document.getElementById('play').textContent = on ? 'pause' : 'play';
}
document.getElementById('play').onclick = () => play(paused);
document.getElementById('speed').onchange = (e) => {
  speed = parseFloat(e.target.value);
  if (audio) audio.playbackRate = speed;
};
const loop = document.getElementById('loop');

// Timeline: music beats above, each dance's motion beats below, the seed shaded, keyframes (orange lines)
// and text intervals (orange bands) marked, the playhead.
const timeline = document.getElementById('timeline');
function drawTimeline(t) {
  const w = (timeline.width = timeline.clientWidth * (window.devicePixelRatio || 1));
  const h = (timeline.height = timeline.clientHeight * (window.devicePixelRatio || 1));
  const g = timeline.getContext('2d');
  const x = (frame) => (frame / fps / duration) * w;
  const rows = 1 + dances.length;
  g.fillStyle = '#e6e6e0';
  dances.forEach((d, i) => g.fillRect(0, ((i + 1) * h) / rows, x(d.seed_frames), h / rows));
  g.fillStyle = '#333';
  for (const f of data.music_beats) g.fillRect(x(f), 0, 1.5, h / rows);
  dances.forEach((d, i) => {
    g.fillStyle = '#' + d.color.toString(16).padStart(6, '0');
    for (const f of d.motion_beats) g.fillRect(x(f), ((i + 1) * h) / rows, 1.5, h / rows);
  });
  dances.forEach((d, i) => {
    for (const m of d.marks || []) {
      const top = ((i + 1) * h) / rows;
      if (m.to > m.from) {
        g.fillStyle = 'rgba(232, 128, 0, 0.3)';
        g.fillRect(x(m.from), top, Math.max(2, x(m.to) - x(m.from)), h / rows);
      } else {
        g.fillStyle = '#e80';
        g.fillRect(x(m.from) - 1.5, top, 3, h / rows);
      }
    }
  });
  g.fillStyle = '#d00';
  g.fillRect((t / duration) * w - 1, 0, 2, h);
}
timeline.onclick = (e) => seek((e.offsetX / timeline.clientWidth) * duration);

function resize() {
  const w = view.clientWidth;
  const h = view.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);
resize();

function frameAt(t) {
  return Math.min(frames - 1, Math.floor(t * fps + 1e-6));
}
function show(t) {
  const frame = frameAt(t);
  pose(frame);
  controls.update();
  renderer.render(scene, camera);
  drawTimeline(t);
  const seeds = dances.filter((d) => frame < d.seed_frames).map((d) => d.label);
  // A keyframe shows for ± 4 frames (half a token), a text over its interval.
  const marked = dances.flatMap((d) =>
    (d.marks || []).filter((m) => frame >= m.from - (m.to > m.from ? 0 : 4) && frame <= m.to + (m.to > m.from ? 0 : 4)).map((m) => m.label),
  );
  status.textContent =
    `t ${t.toFixed(2)} s · frame ${frame} / ${frames}` +
    (seeds.length ? ` · seed of ${seeds.join(', ')}` : '') +
    (marked.length ? ` · ${marked.join(', ')}` : '');
  return frame;
}
let fixed = null;
function tick() {
  if (fixed !== null) {
    show(fixed);
    requestAnimationFrame(tick);
    return;
  }
  let t = now();
  if (t >= duration) {
    if (loop.checked && !paused) seek(0);
    else if (!paused) play(false);
    t = Math.min(t, duration);
  }
  show(t);
  requestAnimationFrame(tick);
}

function ready() {
  if (audio && isFinite(audio.duration) && Math.abs(audio.duration - danceSeconds) > 0.05) {
    const shorter = audio.duration < danceSeconds ? 'the music' : 'the dance';
    document.getElementById('warning').textContent =
      `The music lasts ${audio.duration.toFixed(2)} s and the dance ${danceSeconds.toFixed(2)} s: playing the shorter (${shorter}).`;
  }
  if (audio && isFinite(audio.duration)) duration = Math.min(audio.duration, danceSeconds);
  // Test hook: page.html#t=1.5 shows that instant, paused, and reports it in the title.
  const m = /t=([0-9.]+)/.exec(location.hash);
  if (m) {
    fixed = Math.min(parseFloat(m[1]), duration);
    const frame = show(fixed);
    title(`ready t=${m[1]} frame=${frame} frames=${frames} audio=${audio ? audio.duration.toFixed(3) : 'none'}`);
    requestAnimationFrame(tick);
    return;
  }
  title('ready');
  requestAnimationFrame(tick);
}
if (audio && !(audio.readyState >= 1)) {
  audio.addEventListener('loadedmetadata', ready, { once: true });
  audio.addEventListener('error', () => title('error: the music cannot be decoded'), { once: true });
} else {
  ready();
}
