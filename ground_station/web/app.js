// quadmission ground station page: polls /api/state, draws it, sends commands.
"use strict";
const $ = (id) => document.getElementById(id);
const tokenInput = $("token");
const params = new URLSearchParams(location.hash.slice(1));
if (params.get("token")) tokenInput.value = params.get("token");
let lastRevision = -1, lastCamera = -1, lastChange = Date.now(), sequenceEdited = false;
let robotsShown = "";
function flag(el, value, good = true) {
  el.textContent = value === undefined || value === null ? "-" : (value ? "yes" : "no");
  el.className = value === undefined || value === null ? "" : (value === good ? "ok" : "bad");
}

let diagram = null;  // the mission machine: /api/diagram, fetched once
fetch("api/diagram").then((r) => r.json()).then((d) => { diagram = d; });

function drawFsm(state) {
  const svg = $("fsm");
  const m = state.mission || {};
  const active = m.state || "";
  const lit = (name) => active === name || active.startsWith(name + ".");
  if (!diagram) return;
  const rows = diagram.states;
  const half = Math.ceil(rows.length / 2);
  // split the column at a top-level state so that a nested machine stays in one column
  let split = rows.findIndex((s, i) => i >= half && s.depth === 0);
  if (split < 0) split = rows.length;
  let out = "";
  rows.forEach((s, i) => {
    const col = i < split ? 0 : 1, row = col ? i - split : i;
    const x = 6 + col * 178 + s.depth * 14, y = 4 + row * 21, w = 168 - s.depth * 14;
    const on = lit(s.name);
    const fill = on ? (s.composite ? "#6b5a1e" : "#ffd75e") : (s.composite ? "#222a35" : "#2a3340");
    out += `<g class="state${on ? " active" : ""}" data-state="${s.name}"><title>${s.doc}</title>` +
      `<rect x="${x}" y="${y}" width="${w}" height="18" rx="4" fill="${fill}"` +
      ` stroke="${on ? "#fff" : (s.terminal ? "#c07070" : "#6a7a90")}"/>` +
      `<text x="${x + 6}" y="${y + 13}" style="fill:${on && !s.composite ? "#000" : "#ddd"}">` +
      `${s.composite ? "▾ " : ""}${s.label}</text></g>`;
  });
  const rowsUsed = Math.max(split, rows.length - split);
  svg.setAttribute("viewBox", `0 0 360 ${8 + rowsUsed * 21}`);
  svg.setAttribute("height", String(8 + rowsUsed * 21));
  svg.innerHTML = out;
  const ways = diagram.transitions.filter((t) => lit(t.source))
    .map((t) => `${t.trigger}${t.label ? " " + t.label : ""} → ${t.dest}`);
  $("ways-out").textContent = ways.length ? "next: " + ways.join(" · ") : "";
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
  $("phase").textContent = m.state || m.phase_name || "no /mission/state yet";
  $("sub_state").textContent = (m.phase_name ? `phase ${m.phase_name}` : "") +
    (m.sub_state ? `, ${m.sub_state}` : "") + (m.target_pad_id ? `, pad ${m.target_pad_id}` : "") +
    (m.score !== undefined && m.phase_name ? `, score ${m.score}` : "") +
    (m.stop_reason ? ` — stopped: ${m.stop_reason}` : "");
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
  setTimeout(poll, 250);
  let state = null;
  try {
    const r = await fetch("api/state", { cache: "no-store" });
    if (r.ok) state = await r.json();
  } catch (e) {  // the server is gone; the page keeps trying
    $("live").textContent = "disconnected"; $("live").className = "pill stale";
    return;
  }
  if (state) render(state);  // a drawing error shows in the console (and fails the tests)
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
