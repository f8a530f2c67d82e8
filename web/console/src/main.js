// SPDX-License-Identifier: Apache-2.0
// The console's page: only the documented API (docs/reference/console-api.md).
import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import uPlot from "uplot";

const AXES = ["x", "y", "z", "roll", "pitch", "yaw"];
const $ = (id) => document.getElementById(id);
const now = () => performance.timeOrigin + performance.now(); // ms, Unix epoch
const stats = {
  loaded: now(), firstUpdate: null, updates: 0, times: [], latencies: [], serverAges: [], work: [], renders: [], estopClicks: [], usableAt: null,
};
window.consoleStats = stats;

let client = null;
let pending = null;
let ws = null;
let cfg = null;
let last = null;

// -- HTTP -----------------------------------------------------------------------
async function api(path, body) {
  const opt = body === undefined ? {} : {
    method: "POST", headers: { "Content-Type": "application/json", "X-Console-Client": client || "" },
    body: JSON.stringify(body),
  };
  const r = await fetch(path, opt);
  let j = {};
  try { j = await r.json(); } catch (e) { j = { ok: false, error: `HTTP ${r.status}` }; }
  return { status: r.status, ...j };
}

function say(text, bad) {
  const m = $("message");
  m.textContent = text;
  m.className = "message" + (bad ? " bad" : "");
}

async function command(body) {
  say(`${body.command}...`);
  const r = await api("/api/command", body);
  if (r.ok) say(`${body.command}: ${r.text || r.state}`);
  else say(`${body.command} refused: ${r.error}`, true);
  return r;
}

// -- 3-D view -------------------------------------------------------------------
const view = {};

function setup3d() {
  const el = $("view3d");
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(el.clientWidth, el.clientHeight);
  el.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xffffff);
  THREE.Object3D.DEFAULT_UP.set(0, 0, 1);
  const camera = new THREE.PerspectiveCamera(40, el.clientWidth / el.clientHeight, 0.1, 100);
  camera.up.set(0, 0, 1);
  camera.position.set(6, -6, 4.5);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.set(0, 0, 1.3);
  controls.update();
  controls.addEventListener("change", () => { dirty = true; });
  scene.add(new THREE.AmbientLight(0xffffff, 0.7));
  const sun = new THREE.DirectionalLight(0xffffff, 0.8);
  sun.position.set(3, -4, 8);
  scene.add(sun);
  const grid = new THREE.GridHelper(6, 12, 0xbbbbbb, 0xdddddd);
  grid.rotation.x = Math.PI / 2;
  scene.add(grid);
  scene.add(new THREE.AxesHelper(0.8)); // the work (base) frame
  Object.assign(view, { renderer, scene, camera });
  buildPlatform();
}

function plate(points, z, color) {
  const shape = new THREE.Shape(points.map((p) => new THREE.Vector2(p[0], p[1])));
  const geo = new THREE.ExtrudeGeometry(shape, { depth: 0.06, bevelEnabled: false });
  const mesh = new THREE.Mesh(geo, new THREE.MeshLambertMaterial({ color, transparent: true, opacity: 0.85 }));
  mesh.position.z = z;
  return mesh;
}

function buildPlatform() {
  const b = cfg.base_joints;
  const p = cfg.platform_joints;
  view.scene.add(plate(b, -0.06, 0x666677));
  const top = new THREE.Group();
  top.add(plate(p, p[0][2], 0x3377bb));
  const tool = new THREE.AxesHelper(0.5); // the tool frame: the force/torque sensor's mount
  tool.position.set(...cfg.sensor_mount);
  top.add(tool);
  view.scene.add(top);
  view.top = top;
  view.legs = [];
  for (let i = 0; i < 6; i++) {
    const m = new THREE.Mesh(new THREE.CylinderGeometry(0.045, 0.045, 1, 12),
      new THREE.MeshLambertMaterial({ color: 0x888888 }));
    view.scene.add(m);
    view.legs.push(m);
  }
  view.arrow = new THREE.ArrowHelper(new THREE.Vector3(0, 0, -1), new THREE.Vector3(), 0.5, 0xdd2200, 0.15, 0.08);
  view.arrow.visible = false;
  view.scene.add(view.arrow);
}

function legColour(leg, by) {
  let u = 0;
  if (by === "force" && leg.force !== undefined) u = Math.min(1, Math.abs(leg.force) / cfg.force_max);
  else if (leg.stroke !== undefined) u = Math.min(1, Math.abs(leg.stroke - 0.5) * 2);
  return new THREE.Color().setHSL((1 - u) * 0.33, 0.8, 0.45);
}

function update3d(s) {
  if (!s.pose || !view.top) return;
  const [x, y, z, r, p, yw] = s.pose;
  view.top.position.set(x, y, z);
  view.top.rotation.set(r, p, yw, "ZYX");
  view.top.updateMatrixWorld(true);
  const by = $("colourby").value;
  const up = new THREE.Vector3(0, 1, 0);
  for (let i = 0; i < 6; i++) {
    const a = new THREE.Vector3(...cfg.base_joints[i]);
    const t = new THREE.Vector3(...cfg.platform_joints[i]).applyMatrix4(view.top.matrixWorld);
    const d = t.clone().sub(a);
    const leg = view.legs[i];
    leg.position.copy(a.clone().add(t).multiplyScalar(0.5));
    leg.scale.set(1, d.length(), 1);
    leg.quaternion.setFromUnitVectors(up, d.normalize());
    if (s.legs && s.legs[i]) leg.material.color = legColour(s.legs[i], by);
  }
  const w = s.wrench;
  if (w && w.valid && Math.hypot(...w.values.slice(0, 3)) > 1) {
    const f = new THREE.Vector3(...w.values.slice(0, 3));
    const n = f.length();
    view.arrow.position.set(x, y, z + cfg.platform_joints[0][2] - 0.05);
    view.arrow.setDirection(f.normalize());
    view.arrow.setLength(Math.min(1.5, 0.2 + n / 2000), 0.15, 0.08);
    view.arrow.visible = true;
  } else view.arrow.visible = false;
  dirty = true;
}

function start3d() {
  try { setup3d(); } catch (e) { say(`3-D view unavailable: ${e.message}`, true); }
  stats.view3dAt = now();
  render();
}

let dirty = true;
let lastRender = 0;
function render() {
  // on demand: a new state or a turn of the camera (software WebGL is not free)
  const t = performance.now();
  if (view.renderer && dirty && t - lastRender >= 45) { // <= 22 frames a second
    view.renderer.render(view.scene, view.camera);
    stats.renders.push(performance.now() - t);
    if (stats.renders.length > 100) stats.renders.shift();
    dirty = false;
    lastRender = t;
  }
  requestAnimationFrame(render);
}

// -- plots -----------------------------------------------------------------------
const plots = {};
const WINDOW = 300; // points kept (10 s at 30 Hz)

function mkPlot(id, title, names) {
  const opts = {
    title, width: 380, height: 170, scales: { x: { time: true } },
    series: [{}, ...names.map((n, i) => ({ label: n, stroke: `hsl(${i * 60},70%,45%)`, width: 1 }))],
    legend: { show: true },
  };
  const data = [[], ...names.map(() => [])];
  plots[id] = { u: new uPlot(opts, data, $(id)), data };
}

function pushPlot(id, t, values) {
  const p = plots[id];
  if (!p || !values) return;
  p.data[0].push(t);
  values.forEach((v, i) => p.data[i + 1].push(v));
  if (p.data[0].length > WINDOW) p.data.forEach((a) => a.shift());
}

function drawPlots() {
  for (const p of Object.values(plots)) p.u.setData(p.data);
}

// -- state -----------------------------------------------------------------------
const fmt = (v, k = 1, d = 1) => (v === undefined || v === null ? "-" : (v * k).toFixed(d));

function showState(s) {
  const st = $("state");
  st.textContent = s.state || "no status";
  st.className = `badge state-${s.state}`;
  $("forcemode").textContent = s.force_mode && s.force_mode !== "OFF"
    ? `force ${s.force_mode}${s.contact ? " in contact" : ""}` : "";
  $("faults").innerHTML = (s.faults || []).map((f) => `<span class="fault">${f}</span>`).join("");
  $("bus").textContent = s.bus_problem || "";
  $("ff").checked = !!s.feedforward;
  const c = s.control || {};
  const me = c.commander && c.commander === client;
  $("role").textContent = me ? "you command" : c.commander ? `observing (${c.commander_name || c.commander} commands)`
    : "observing (nobody commands)";
  $("claim").textContent = c.commander && !me ? "Take over" : "Take command";
  document.body.dataset.role = me ? "commander" : "observer";
  if (s.pose) {
    $("posetext").textContent = s.pose.map((v, i) => `${AXES[i]} ${fmt(v - cfg.home[i], 1000)}`).join("  ");
  }
  const rows = (s.legs || []).map((l) => `<tr><td>${l.leg}</td><td>${fmt(l.length ?? l.length_sp, 1000)}</td>`
    + `<td>${fmt(l.stroke, 100)}</td><td>${fmt(l.speed, 1000)}</td><td>${fmt(l.force_ff, 1e-3, 2)}</td>`
    + `<td>${fmt(l.force, 1e-3, 2)}</td><td>${fmt(l.pressure_a, 1e-5)}</td><td>${fmt(l.pressure_b, 1e-5)}</td>`
    + `<td>${l.state || "-"}${l.faults && l.faults.length ? " " + l.faults.join(",") : ""}</td></tr>`);
  $("legs").tBodies[0].innerHTML = rows.join("");
  const r = s.recording || {};
  $("recinfo").textContent = r.active ? `recording ${r.name}: ${r.frames} frames, ${r.seconds.toFixed(1)} s` : "";
}

function showEvents(events) {
  const ol = $("events");
  for (const e of events) {
    const li = document.createElement("li");
    li.textContent = `${new Date(e.t * 1000).toLocaleTimeString()} ${e.text}`;
    if (!e.ok) li.className = "bad";
    ol.prepend(li);
  }
  while (ol.children.length > 50) ol.lastChild.remove();
}

function onState(s) {
  const t0 = performance.now();
  last = s;
  showState(s);
  update3d(s);
  if (s.events) showEvents(s.events);
  const t = s.t;
  pushPlot("plot-error", t, s.tracking_error && s.tracking_error.map((v) => v * 1000));
  pushPlot("plot-wrench", t, s.wrench && s.wrench.values);
  pushPlot("plot-ft", t, s.ft);
  pushPlot("plot-contact", t, [s.contact ? 1 : 0, s.force_mode && s.force_mode !== "OFF" ? 1 : 0]);
  const shown = now();
  stats.work.push(performance.now() - t0);
  if (stats.work.length > 100) stats.work.shift();
  stats.updates += 1;
  stats.times.push(shown);
  if (s.bus_stamp) {
    stats.latencies.push(shown - s.bus_stamp * 1000);
    stats.serverAges.push((s.t - s.bus_stamp) * 1000); // of it, in the server: bus frame to the send
  }
  if (stats.times.length > 600) { stats.times.shift(); stats.latencies.shift(); stats.serverAges.shift(); }
  if (stats.firstUpdate === null) {
    stats.firstUpdate = shown;
    stats.usableAt = shown;
    setTimeout(start3d, 0); // after the state is on screen: software WebGL takes a while to start
  }
  if (stats.updates % 30 === 0) showStats();
}

function showStats() {
  const n = stats.times.length;
  const rate = n > 1 ? (1000 * (n - 1)) / (stats.times[n - 1] - stats.times[0]) : 0;
  const lat = [...stats.latencies].sort((a, b) => a - b);
  stats.rate = rate;
  $("stats").textContent = `updates ${rate.toFixed(1)} /s, bus frame to screen median `
    + `${(lat[Math.floor(lat.length / 2)] || 0).toFixed(1)} ms, max ${(lat[lat.length - 1] || 0).toFixed(1)} ms`;
}

// -- WebSocket --------------------------------------------------------------------
function connect() {
  const proto = location.protocol === "https:" ? "wss" : "ws";
  ws = new WebSocket(`${proto}://${location.host}/api/ws?name=browser${client ? "&client=" + client : ""}`);
  ws.onmessage = (ev) => {
    const m = JSON.parse(ev.data);
    if (m.type === "state") {
      // only the newest state is shown: a page that falls behind skips, it never queues
      if (pending === null) setTimeout(() => { const s = pending; pending = null; onState(s); }, 0);
      pending = m;
    }
    else if (m.type === "hello") client = m.client;
    else if (m.type === "estop") say(m.ok ? `ESTOP: ${m.state}` : `ESTOP: ${m.error}`, !m.ok);
  };
  ws.onclose = () => { say("connection to the console lost: reconnecting...", true); setTimeout(connect, 1000); };
}

function estop() {
  stats.estopClicks.push(now());
  if (ws && ws.readyState === 1) ws.send(JSON.stringify({ type: "estop" }));
  else api("/api/estop", {}).then((r) => say(r.ok ? "ESTOP sent" : `ESTOP: ${r.error}`, !r.ok));
}

// -- controls ------------------------------------------------------------------------
function num(id) { return Number($(id).value); }

function sixInputs(id, prefix) {
  $(id).innerHTML = AXES.map((a) => `${a} <input id="${prefix}-${a}" value="0">`).join(" ");
}

function sixValues(prefix, k) { return AXES.map((a) => Number($(`${prefix}-${a}`).value) * k); }

function setupJog() {
  const jog = $("jog");
  for (const a of AXES) {
    for (const sign of [-1, 1]) {
      const b = document.createElement("button");
      b.textContent = `${a} ${sign > 0 ? "+" : "-"}`;
      b.dataset.jog = `${a}:${sign}`;
      let held = false;
      const go = async () => {
        while (held) {
          const r = await command({ command: "jog", axis: a, step: sign * num("jogstep") / 1000 });
          if (!r.ok) break;
        }
      };
      b.addEventListener("pointerdown", () => { held = true; go(); });
      for (const ev of ["pointerup", "pointerleave", "pointercancel"]) b.addEventListener(ev, () => { held = false; });
      jog.appendChild(b);
    }
  }
}

function forceBody(cmd) {
  const body = { command: cmd, axes: $("faxes").value };
  if (cmd === "force") body.target = sixValues("ft", 1);
  if ($("fparams").checked) body.params = { mass: num("fmass"), damping: num("fdamp"), stiffness: num("fstiff") };
  return body;
}

async function claim() {
  const takeover = $("claim").textContent === "Take over";
  if (takeover && !confirm("Take command over from the current commander?")) return;
  const r = await api("/api/control", { action: "claim", takeover });
  say(r.ok ? "you command" : `cannot take command: ${r.error}`, !r.ok);
}

async function recordings() {
  let items = [];
  try { items = await (await fetch("/api/recordings")).json(); } catch (e) { items = []; }
  if (!Array.isArray(items)) items = [];
  $("recordings").innerHTML = items.slice(0, 5).map((r) => `<div>${r.name}: `
    + `<a href="/api/recordings/${r.name}/log" download>candump log</a> `
    + (r.csv ? `<a href="/api/recordings/${r.name}/csv" download>CSV</a> ` : (r.analysing ? "analysing... " : ""))
    + (r.plots.length ? `<a href="#" data-analysis="${r.name}">plots</a>` : "") + (r.error ? ` (${r.error})` : "")
    + "</div>").join("");
  for (const a of document.querySelectorAll("[data-analysis]")) {
    a.onclick = (ev) => {
      ev.preventDefault();
      const r = items.find((x) => x.name === a.dataset.analysis);
      $("analysis").innerHTML = `<h2>${r.name}</h2>`
        + r.plots.map((p) => `<img src="/api/recordings/${r.name}/${p}" alt="${p}">`).join("");
    };
  }
}

function setupControls() {
  sixInputs("movepose", "mp");
  sixInputs("ftarget", "ft");
  $("runaxis").innerHTML = AXES.map((a) => `<option>${a}</option>`).join("");
  for (const b of document.querySelectorAll("[data-cmd]")) b.onclick = () => command({ command: b.dataset.cmd });
  $("reset").onclick = () => command({ command: "reset" });
  $("ff").onchange = () => command({ command: "feedforward", on: $("ff").checked });
  $("move").onclick = () => command({ command: "move", relative: true,
    pose: AXES.map((a) => Number($(`mp-${a}`).value) / 1000) });
  $("run").onclick = () => command({ command: "run", axis: $("runaxis").value, amplitude: num("runamp"),
    frequency: num("runfreq"), fade: num("runfade") });
  $("force").onclick = () => command(forceBody("force"));
  $("guide").onclick = () => command(forceBody("guide"));
  $("claim").onclick = claim;
  $("release").onclick = () => api("/api/control", { action: "release" }).then((r) => say(r.ok ? "released" : r.error, !r.ok));
  $("estop").onclick = estop;
  document.addEventListener("keydown", (e) => { if (e.key === "Escape") { e.preventDefault(); estop(); } });
  $("recstart").onclick = () => api("/api/recording", { action: "start" }).then((r) => say(r.ok ? `recording ${r.name}` : r.error, !r.ok));
  $("recstop").onclick = () => api("/api/recording", { action: "stop" }).then((r) => {
    say(r.ok ? `recording ${r.name} stopped (${r.frames} frames); analysing` : r.error, !r.ok);
    setTimeout(recordings, 500);
  });
  setupJog();
  setInterval(recordings, 3000);
}

async function main() {
  cfg = await api("/api/config");
  setupControls();
  connect(); // the state first: the page is usable once it shows
  mkPlot("plot-error", "tracking error (mm, mrad)", AXES);
  mkPlot("plot-wrench", "wrench estimate (N, N m)", ["Fx", "Fy", "Fz", "Mx", "My", "Mz"]);
  mkPlot("plot-ft", "force/torque sensor (N, N m)", ["Fx", "Fy", "Fz", "Mx", "My", "Mz"]);
  mkPlot("plot-contact", "contact, force control", ["contact", "force control"]);
  setInterval(drawPlots, 100);
  recordings();
}

main();
