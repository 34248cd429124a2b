// rig watch: follows one session (or lists a directory's) through the server's JSON state and SVG figures.
// Read-only: it only ever GETs. Nothing here is computed from the data; the server does that.
"use strict";

const $ = (id) => document.getElementById(id);
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

// What the page has shown, for a person's browser console and for tests: one entry per state shown.
window.rigWatch = { updates: [], figures: {} };

function duration(s) {
  if (s === null || s === undefined) return "–";
  s = Math.max(0, Math.round(s));
  const h = Math.floor(s / 3600), m = Math.floor(s / 60) % 60, sec = s % 60;
  return `${h}:${String(m).padStart(2, "0")}:${String(sec).padStart(2, "0")}`;
}

function num(x, digits = 4) {
  if (x === null || x === undefined) return "–";
  return Number(x).toPrecision(digits).replace(/\.?0+(e|$)/, "$1");
}

function clock(unix) {
  return new Date(unix * 1000).toLocaleTimeString();
}

function setText(id, text) {
  const el = $(id);
  if (el && el.textContent !== text) el.textContent = text;
}

function showStatus(s) {
  const badge = $("status");
  badge.textContent = s.status || "waiting";
  badge.className = "badge " + (s.status || "none") + (s.status === "running" && !s.writer_alive ? " stalled" : "");
  setText("status-text", s.status_text || "");
}

function showProgress(s) {
  const p = s.progress;
  if (!p) return;
  const pct = Math.round(1000 * p.fraction) / 10;
  $("bar-fill").style.width = `${pct}%`;
  document.querySelector(".bar").setAttribute("aria-valuenow", String(pct));
  setText("points", `${p.n_applied} of ${p.n_points} (${pct} %)`);
  setText("measured", `${p.n_measured} of ${p.n_planned_measured} planned`);
  setText("rig-time", duration(p.rig_time_s) + (s.clock === "virtual" ? " (virtual clock)" : ""));
  setText("planned", p.planned_rig_time_s === null ? "not known (no dwell plan)" :
    (p.planned_exact ? "" : "at most ") + duration(p.planned_rig_time_s));
  setText("eta", p.eta_s === null ? (s.status === "running" ? "–" : "none: not running") : duration(p.eta_s));
  setText("wall", duration(p.wall_elapsed_s));
  const q = s.quantities, last = s.last;
  setText("last", last === null ? "–" :
    `#${last.index}: ${num(last.input)} ${q.input_unit} → ` +
    (last.output === null ? "not measured" : `${num(last.output)} ${q.output_unit}`) +
    ` at ${duration(last.t_s)}`);
  const e = s.excitation;
  setText("excitation", e.kind + (e.levels ? `, L = ${e.levels} on [${num(e.v_min)}, ${num(e.v_max)}] ${q.input_unit}` : "") +
    (e.thermal_term ? ", thermal point" : "") + (e.dwell ? `, ${e.dwell} dwell` : ""));
  setText("cap-time", `${q.input} and ${q.output} against time`);
  setText("cap-loop", `Hysteresis loop: ${q.output} against ${q.input}, heating and cooling branches`);
}

function showModel(s) {
  const m = s.model, q = s.quantities;
  if (!m) return;
  if (m.status !== "fitted") {
    setText("model-text", `${m.method}: ${m.status}`);
    $("model-note").hidden = true;
    return;
  }
  setText("model-text",
    `${m.method}, L = ${m.levels}, fitted on ${m.n_used} measured points of the first ${m.n_samples}` +
    (m.behind ? ` (${m.behind} newer point${m.behind === 1 ? "" : "s"} not yet fitted)` : "") +
    `: RMSE ${num(m.rmse)} ${q.output_unit} (${num(100 * m.nrmse, 3)} % of the range), ` +
    `mu0 = ${num(m.mu0)} ${q.output_unit}` + (m.thermal_term ? `, c_d = ${num(m.c_d)} ${m.c_d_unit}` : "") +
    `; fit ${num(m.seconds, 2)} s.`);
  const note = [m.note, m.error ? `last refit failed: ${m.error}` : ""].filter(Boolean).join(" ");
  $("model-note").hidden = !note;
  setText("model-note", note);
}

function showWhere(s) {
  const w = s.where;
  $("where").hidden = !w;
  $("fig-where").hidden = !w;
  if (!w) return;
  setText("where-text", w.status === "diagnosed"
    ? `${w.verdict}${w.effect ? " by " + w.effect : ""} on ${w.n_check} check points: ${w.reason}`
    : w.status);
}

function showEvents(s) {
  const ol = $("events");
  const items = (s.events || []).map((e) => `${clock(e.t_unix)}  ${e.event} (${e.status}, ${e.n_samples} samples)` +
    (e.message ? `: ${e.message}` : ""));
  if (ol.dataset.items === JSON.stringify(items)) return;
  ol.dataset.items = JSON.stringify(items);
  ol.replaceChildren(...items.map((t) => { const li = document.createElement("li"); li.textContent = t; return li; }));
}

function markStale(stale) {
  for (const fig of document.querySelectorAll("#figures figure")) {
    const name = fig.querySelector(".plot").dataset.figure;
    fig.toggleAttribute("data-stale", (stale || []).includes(name));
  }
}

async function showFigures(figs) {
  for (const [name, version] of Object.entries(figs || {})) {
    if (window.rigWatch.figures[name] === version) continue;
    const box = document.querySelector(`[data-figure="${name}"]`);
    if (!box) continue;
    const r = await fetch(`figure/${name}.svg?v=${version}`, { cache: "no-store" });
    if (!r.ok) continue;
    const doc = new DOMParser().parseFromString(await r.text(), "image/svg+xml");
    const svg = doc.documentElement;
    if (svg.nodeName !== "svg") continue;
    svg.removeAttribute("width");
    svg.removeAttribute("height");
    svg.setAttribute("role", "img");
    box.replaceChildren(document.importNode(svg, true));
    window.rigWatch.figures[name] = version;
  }
}

async function followSession() {
  if (location.pathname.startsWith("/s/")) $("crumbs").hidden = false;
  let version = 0;
  for (;;) {
    let s;
    try {
      const r = await fetch(`api/state?after=${version}&wait=20`, { cache: "no-store" });
      if (r.status === 403) {
        setText("status-text", "access token needed: open the address rig watch printed (…?token=…)");
        return;
      }
      if (!r.ok) throw new Error(`HTTP ${r.status}`);
      s = await r.json();
    } catch (err) {
      setText("conn", `Connection to rig watch lost (${err.message}); retrying.`);
      await sleep(2000);
      continue;
    }
    setText("conn", "");
    version = s.version;
    document.title = `${s.session}: ${s.status || "waiting"} – rig watch`;
    setText("title", s.session);
    setText("path", s.path);
    setText("updated", clock(s.updated_unix));
    showStatus(s);
    if (s.progress) {
      showProgress(s);
      showModel(s);
      showWhere(s);
      showEvents(s);
    }
    markStale(s.stale);
    await showFigures(s.figures);
    const u = window.rigWatch.updates;
    u.push({ version, n: s.progress ? s.progress.n_applied : 0, status: s.status, shown_ms: Date.now(),
             figures: { ...window.rigWatch.figures }, drawn: { ...(s.drawn || {}) } });
    if (u.length > 1000) u.splice(0, u.length - 1000);
  }
}

async function listSessions() {
  for (;;) {
    try {
      const r = await fetch("api/sessions", { cache: "no-store" });
      if (!r.ok) throw new Error(`HTTP ${r.status}`);
      const d = await r.json();
      setText("directory", d.directory);
      $("empty").hidden = d.sessions.length > 0;
      const rows = d.sessions.map((x) => {
        const tr = document.createElement("tr");
        const a = document.createElement("a");
        a.href = `/s/${encodeURIComponent(x.name)}/`;
        a.textContent = x.name;
        const cells = [a, x.error ? `unreadable: ${x.error}` : x.status,
          x.n_points === null ? "–" : `${x.n_samples} of ${x.n_points}`, new Date(x.modified_unix * 1000).toLocaleString()];
        for (const c of cells) {
          const td = document.createElement("td");
          if (typeof c === "string") td.textContent = c; else td.appendChild(c);
          tr.appendChild(td);
        }
        return tr;
      });
      document.querySelector("#sessions tbody").replaceChildren(...rows);
      setText("conn", "");
    } catch (err) {
      setText("conn", `Connection to rig watch lost (${err.message}); retrying.`);
    }
    await sleep(2000);
  }
}

if ($("sessions")) listSessions(); else followSession();
