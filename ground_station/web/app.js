// quadmission ground station page: polls /api/state, draws it, sends commands.
"use strict";
const $ = (id) => document.getElementById(id);
const tokenInput = $("token");
const params = new URLSearchParams(location.hash.slice(1));
if (params.get("token")) tokenInput.value = params.get("token");
let lastRevision = -1, lastCamera = -1, lastChange = Date.now(), sequenceEdited = false;
let robotsShown = "";
const PHASE_FLOW = ["idle", "preflight", "takeoff", "explore", "report_robot",
  "await_sequence", "landing_sequence", "return_home", "completed"];

function flag(el, value, good = true) {
  el.textContent = value === undefined || value === null ? "-" : (value ? "yes" : "no");
  el.className = value === undefined || value === null ? "" : (value === good ? "ok" : "bad");
}

function drawFsm(state) {
  const svg = $("fsm");
  const phases = Object.values(state.phases || {});
  const active = state.mission && state.mission.phase_name;
  const flow = PHASE_FLOW.filter((p) => phases.includes(p));
  const side = phases.filter((p) => !flow.includes(p));
  let out = '<defs><marker id="arr" markerWidth="6" markerHeight="6" refX="5" refY="3" orient="auto">' +
    '<path d="M0,0 L6,3 L0,6 z" fill="#888"/></marker></defs>';
  const box = (name, x, y, w) => {
    const on = name === active;
    return `<g class="state${on ? " active" : ""}" data-state="${name}">` +
      `<rect x="${x}" y="${y}" width="${w}" height="20" rx="4" fill="${on ? "#ffd75e" : "#2a3340"}"` +
      ` stroke="${on ? "#fff" : "#6a7a90"}"/>` +
      `<text x="${x + w / 2}" y="${y + 14}" text-anchor="middle" style="fill:${on ? "#000" : "#ddd"}">` +
      `${name}</text></g>`;
  };
  flow.forEach((name, i) => {
    const y = 4 + i * 27;
    out += box(name, 10, y, 150);
    if (i + 1 < flow.length)
      out += `<line x1="85" y1="${y + 20}" x2="85" y2="${y + 27}" stroke="#888" marker-end="url(#arr)"/>`;
  });
  side.forEach((name, i) => {
    const y = 60 + i * 80;
    out += box(name, 220, y, 120);
    out += `<text x="280" y="${y + 34}" text-anchor="middle">from any mission state</text>`;
    out += `<line x1="162" y1="${y + 10}" x2="218" y2="${y + 10}" stroke="#888" stroke-dasharray="3,3" marker-end="url(#arr)"/>`;
  });
  svg.innerHTML = out;
}

function drawMap(state) {
  const canvas = $("map"), ctx = canvas.getContext("2d");
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  const layout = state.layout;
  const size = layout ? layout.size : [20, 14];
  const margin = 20;
  const scale = Math.min((canvas.width - 2 * margin) / size[0], (canvas.height - 2 * margin) / size[1]);
  const X = (x) => margin + x * scale, Y = (y) => canvas.height - margin - y * scale;
  ctx.strokeStyle = "#8899aa"; ctx.lineWidth = 2;
  ctx.strokeRect(X(0), Y(size[1]), size[0] * scale, size[1] * scale);
  if (layout) {
    const robot = state.mission && state.mission.robot_marker_id;
    const found = robot || (state.robots.length ? state.robots[0].marker_id : 0);
    const points = found ? (layout.points[String(found)] || {}) : {};
    for (const o of layout.obstacles) {
      ctx.fillStyle = o.height > 1.0 ? "#8a8a8a" : "#5d5d5d";
      ctx.fillRect(X(o.center[0] - o.size[0] / 2), Y(o.center[1] + o.size[1] / 2), o.size[0] * scale, o.size[1] * scale);
    }
    ctx.font = "12px sans-serif";
    for (const p of layout.pads) {
      const landed = state.mission && (state.mission.pads_landed || []).includes(p.id);
      const target = state.mission && state.mission.target_pad_id === p.id;
      ctx.fillStyle = landed ? "#2e7d32" : (target ? "#ffd75e" : "#7fd6ff");
      ctx.fillRect(X(p.center[0] - p.side / 2), Y(p.center[1] + p.side / 2), p.side * scale, p.side * scale);
      ctx.fillStyle = "#000";
      ctx.fillText(String(p.id), X(p.center[0]) - 6, Y(p.center[1]) + 4);
      if (points[String(p.id)] !== undefined) {
        ctx.fillStyle = "#fff";
        ctx.fillText(points[String(p.id)] + " pts", X(p.center[0]) - 14, Y(p.center[1] - p.side / 2) + 14);
      }
    }
  }
  if (state.map && state.map.length) {
    ctx.fillStyle = "rgba(199,139,255,0.5)";
    for (const [x, y] of state.map) ctx.fillRect(X(x) - 1, Y(y) - 1, 2, 2);
  }
  const line = (pts, color, width) => {
    if (!pts || pts.length < 2) return;
    ctx.strokeStyle = color; ctx.lineWidth = width; ctx.beginPath();
    pts.forEach(([x, y], i) => (i ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y))));
    ctx.stroke();
  };
  line(state.planned, "#7cf07c", 2);
  line(state.flown, "#ffb347", 2);
  for (const r of state.robots) {
    ctx.fillStyle = "#ff6b6b"; ctx.beginPath(); ctx.arc(X(r.x), Y(r.y), 6, 0, 2 * Math.PI); ctx.fill();
    ctx.fillText("robot " + r.marker_id, X(r.x) + 8, Y(r.y));
  }
  const pose = state.pose;
  if (pose) {
    const x = X(pose.x), y = Y(pose.y), h = pose.yaw;
    ctx.save(); ctx.translate(x, y); ctx.rotate(-h);
    ctx.fillStyle = "#ffffff"; ctx.beginPath();
    ctx.moveTo(14, 0); ctx.lineTo(-8, 7); ctx.lineTo(-4, 0); ctx.lineTo(-8, -7); ctx.closePath(); ctx.fill();
    ctx.restore();
  }
}

function render(state) {
  $("t_s").textContent = state.t_s.toFixed(1);
  $("revision").textContent = state.revision;
  if (state.revision !== lastRevision) { lastRevision = state.revision; lastChange = Date.now(); }
  const pill = $("live");
  const live = Date.now() - lastChange < 3000;
  pill.textContent = live ? "live" : "no data"; pill.className = "pill " + (live ? "live" : "stale");
  $("pose").textContent = state.pose ?
    `x ${state.pose.x.toFixed(2)} y ${state.pose.y.toFixed(2)} z ${state.pose.z.toFixed(2)} m, heading ${(state.pose.yaw * 180 / Math.PI).toFixed(0)} deg` : "no pose yet";
  const m = state.mission || {};
  $("phase").textContent = m.phase_name ? m.phase_name : "no /mission/state yet";
  $("sub_state").textContent = m.sub_state ? `${m.sub_state}` + (m.target_pad_id ? ` (pad ${m.target_pad_id})` : "") : "";
  drawFsm(state);
  const f = state.fcu || {};
  flag($("link"), f.connected); flag($("armed"), f.armed); flag($("offboard"), f.offboard);
  flag($("landed"), f.landed); flag($("failsafe"), f.failsafe, false);
  $("battery").textContent = f.battery_remaining === undefined || f.battery_remaining === null ? "-" :
    `${Math.round(f.battery_remaining * 100)} %` + (f.battery_warning ? ` (warning ${f.battery_warning})` : "");
  $("battery").className = f.battery_warning ? "bad" : (f.battery_remaining !== undefined ? "ok" : "");
  const ts = state.timesync || {};
  $("timesync").textContent = ts.samples === undefined ? "-" :
    `${ts.converged ? "converged" : "converging"}, offset ${ts.offset_us} us, rtt ${ts.rtt_us} us`;
  $("timesync").className = ts.samples === undefined ? "" : (ts.converged ? "ok" : "warn");
  const h = state.health || {};
  $("modules").textContent = h.modules ? h.modules.map((x) => `${x.name}: ${x.level}`).join(", ") : "-";
  if (state.camera_revision !== lastCamera) {
    lastCamera = state.camera_revision;
    if (lastCamera > 0) $("camera").src = "api/camera.jpg?r=" + lastCamera;
  }
  const robots = state.robots.map((r) => `${r.marker_id}:${r.picture}`).join(",");
  if (robots !== robotsShown) {
    robotsShown = robots;
    $("robots").innerHTML = state.robots.length ? state.robots.map((r) =>
      `<figure><a href="api/robot/${r.marker_id}.jpg" target="_blank">` +
      (r.picture ? `<img src="api/robot/${r.marker_id}.jpg?s=${r.sightings}" alt="robot ${r.marker_id}">` : "") +
      `</a><figcaption>robot ${r.marker_id} at (${r.x.toFixed(1)}, ${r.y.toFixed(1)})</figcaption></figure>`).join("") : "none yet";
  }
  const proposal = state.proposal && state.proposal.length ? state.proposal : (m.landing_sequence || []);
  if (!sequenceEdited && proposal.length) {
    $("sequence").value = proposal.join(", ");
    $("proposal-note").textContent = "(the optimiser's proposal; edit before sending)";
  }
  $("events").innerHTML = state.events.slice().reverse().map((e) =>
    `<li class="${e.severity === "error" ? "bad" : (e.severity === "warn" ? "warn" : "")}">${e.t_s.toFixed(1)} s ${e.kind}: ${e.message}</li>`).join("");
  $("commands").innerHTML = state.commands.slice().reverse().map((c) =>
    `<li class="${c.accepted ? "ok" : "bad"}">${c.command}${c.sequence && c.sequence.length ? " [" + c.sequence.join(", ") + "]" : ""}: ${c.accepted ? "sent" : "refused (" + c.reason + ")"}</li>`).join("");
  drawMap(state);
}

async function poll() {
  try {
    const r = await fetch("api/state", { cache: "no-store" });
    if (r.ok) render(await r.json());
  } catch (e) { $("live").textContent = "disconnected"; $("live").className = "pill stale"; }
  setTimeout(poll, 250);
}

async function send(body) {
  const status = $("command-status");
  const headers = { "Content-Type": "application/json" };
  if (tokenInput.value) headers["Authorization"] = "Bearer " + tokenInput.value;
  const r = await fetch("api/command", { method: "POST", headers, body: JSON.stringify(body) });
  const reply = await r.json();
  status.textContent = reply.ok ? `${reply.command} sent` : reply.error;
  status.className = reply.ok ? "ok" : "bad";
}

document.querySelectorAll("button[data-command]").forEach((b) =>
  b.addEventListener("click", () => send({ command: b.dataset.command, reason: "operator page" })));
$("sequence").addEventListener("input", () => { sequenceEdited = true; });
$("send-sequence").addEventListener("click", () => {
  const text = $("sequence").value.trim();
  const pads = text ? text.split(/[\s,]+/).map((s) => Number(s)) : [];
  if (pads.some((p) => !Number.isInteger(p))) {
    $("command-status").textContent = "the sequence holds pad numbers, e.g. 3, 7, 2";
    $("command-status").className = "bad";
    return;
  }
  send({ command: "sequence", sequence: pads, reason: "operator page" });
});
poll();
