// facslab studio: sliders per Action Unit, FACS notation kept in step both ways, a live preview
// rendered by the server (latest request wins), exports, undo/redo and the state in the URL.
// The timeline editor is in timeline.js (loaded first; `wireTimeline` is called from `start`).
"use strict";

const LEVELS = [["A", 0.15], ["B", 0.30], ["C", 0.55], ["D", 0.85], ["E", 1.0]];
const REGIONS = [["upper", "Upper face"], ["lower", "Lower face"], ["head_eye", "Head and eyes"]];
const $ = (id) => document.getElementById(id);

const state = {
  catalog: null,          // { aus, people, presets, defaults }
  pose: new Map(),        // AU code -> { value in (0, 1], side "B" | "L" | "R" }
  notation: "0",
  identity: "wm1",
  size: "485x480",
  history: [],            // steps before `current`, for undo: { notation, tl, fps } (see `snapshot`)
  current: null,          // the last step recorded
  future: [],             // steps undone, for redo
  requested: 0,           // id of the newest preview request sent
  shown: 0,               // id of the newest preview shown
  inflight: null,         // AbortController of the preview request under way
  timer: 0,
};

// ---- notation <-> pose ------------------------------------------------------------------

function intensityText(value) {
  const level = LEVELS.find(([, v]) => Math.abs(v - value) < 1e-9);
  if (level) return level[0] === "E" ? "" : level[0];
  return "@" + String(Math.round(value * 100) / 100);
}

function toNotation(pose) {
  const terms = [...pose.entries()]
    .filter(([, a]) => a.value > 0)
    .sort(([a], [b]) => a - b)
    .map(([code, a]) => (a.side === "B" ? "" : a.side) + code + intensityText(a.value));
  return terms.length ? terms.join("+") : "0";
}

// Parses notation into a pose; returns { pose } or { error, token, column }.
function parseNotation(text) {
  const pose = new Map();
  const trimmed = text.trim();
  if (trimmed === "" || trimmed === "0") return { pose };
  let column = 1;
  for (const raw of text.split("+")) {
    const token = raw.trim();
    const at = column + (raw.length - raw.trimStart().length);
    column += raw.length + 1;
    const m = /^([LR]?)(?:AU|au)?(\d+)([A-E]|@(?:\d+(?:\.\d*)?|\.\d+))?$/.exec(token);
    if (!m) return { error: token ? "not an AU term" : "empty term", token, column: at };
    const code = Number(m[2]);
    const unit = state.catalog.aus.find((u) => u.code === code);
    if (!unit) return { error: `AU ${code} is not in the catalog`, token, column: at };
    if (m[1] && !unit.unilateral) return { error: `AU ${code} cannot be shown on one side only`, token, column: at };
    let value = 1;
    if (m[3] && m[3][0] === "@") value = Number(m[3].slice(1));
    else if (m[3]) value = LEVELS.find(([l]) => l === m[3])[1];
    if (!(value >= 0 && value <= 1)) return { error: `intensity ${m[3]} is outside [0, 1]`, token, column: at };
    pose.set(code, { value, side: m[1] || "B" });
  }
  return { pose };
}

// ---- the sliders ------------------------------------------------------------------------

function slider(unit) {
  const row = document.createElement("div");
  row.className = "au";
  row.dataset.code = unit.code;
  row.dataset.search = `au${unit.code} ${unit.code} ${unit.name}`.toLowerCase();
  const id = `au-${unit.code}`;
  row.innerHTML = `<label for="${id}" title="${unit.appearance.replace(/"/g, "&quot;")}"><b>${unit.code}</b> ${unit.name}</label>
    <input id="${id}" type="range" min="0" max="1" step="0.01" value="0" list="levels" aria-label="AU${unit.code} ${unit.name} intensity">
    <output for="${id}">0</output>`;
  if (unit.unilateral) {
    const side = document.createElement("select");
    side.className = "side";
    side.setAttribute("aria-label", `AU${unit.code} side`);
    side.innerHTML = `<option value="B">both</option><option value="L">left</option><option value="R">right</option>`;
    side.addEventListener("change", () => fromSliders(true));
    row.append(side);
  }
  const range = row.querySelector("input");
  range.addEventListener("input", () => fromSliders(false));
  range.addEventListener("change", () => fromSliders(true));
  return row;
}

function buildSliders() {
  const groups = $("groups");
  const ticks = document.createElement("datalist");
  ticks.id = "levels";
  ticks.innerHTML = LEVELS.map(([l, v]) => `<option value="${v}" label="${l}"></option>`).join("");
  groups.append(ticks);
  for (const [region, title] of REGIONS) {
    const box = document.createElement("details");
    box.open = true;
    box.className = "group";
    box.innerHTML = `<summary>${title}</summary>`;
    for (const unit of state.catalog.aus.filter((u) => u.region === region)) box.append(slider(unit));
    groups.append(box);
  }
}

function showPose() {
  for (const row of document.querySelectorAll(".au")) {
    const active = state.pose.get(Number(row.dataset.code));
    row.querySelector("input").value = active ? active.value : 0;
    row.querySelector("output").textContent = active ? (intensityText(active.value) || "E") : "0";
    const side = row.querySelector(".side");
    if (side) side.value = active ? active.side : "B";
    row.classList.toggle("on", Boolean(active));
  }
}

function fromSliders(commit) {
  const pose = new Map();
  for (const row of document.querySelectorAll(".au")) {
    const value = Number(row.querySelector("input").value);
    const side = row.querySelector(".side");
    if (value > 0) pose.set(Number(row.dataset.code), { value, side: side ? side.value : "B" });
  }
  state.pose = pose;
  setNotation(toNotation(pose), commit, false);
}

// ---- state changes ----------------------------------------------------------------------

function setNotation(text, commit, moveSliders) {
  state.notation = text;
  if ($("notation").value !== text && document.activeElement !== $("notation")) $("notation").value = text;
  if (moveSliders) {
    const parsed = parseNotation(text);
    if (parsed.error) return showError(parsed);
    state.pose = parsed.pose;
  }
  showError(null);
  showPose();
  showTruth();
  saveUrl();
  schedulePreview();
  if (commit) checkpoint();
}

function showError(err) {
  const box = $("notation-error");
  box.hidden = !err;
  $("notation").classList.toggle("invalid", Boolean(err));
  if (err) box.textContent = `token "${err.token}" at column ${err.column}: ${err.error}`;
}

function showTruth() {
  const list = $("truth");
  list.innerHTML = "";
  const entries = [...state.pose.entries()].sort(([a], [b]) => a - b);
  if (!entries.length) list.innerHTML = "<li>neutral (no AU)</li>";
  for (const [code, a] of entries) {
    const unit = state.catalog.aus.find((u) => u.code === code);
    const side = { B: "", L: " (left)", R: " (right)" }[a.side];
    const li = document.createElement("li");
    li.textContent = `AU${code} ${unit.name}${side}: ${Math.round(a.value * 100)} % (${intensityText(a.value) || "E"})`;
    list.append(li);
  }
  $("spec-entry").value =
    `[[group]]\nname = "studio"\nexpressions = ["${state.notation}"]\nstills = [1.0]\nidentity = "${state.identity}"\n` +
    `size = [${state.size.replace("x", ", ")}]  # set-level field: move to the top of the spec\n`;
}

// ---- undo/redo ----------------------------------------------------------------------------

// A step is the face and the timeline as the URL keeps them. Committed changes record one:
// a slider let go, a notation entered, a preset, a timeline handle dropped after its drag, a
// number field changed, a track added or removed, a layout switch, a CPT sequence, an import.
// The person, size and look pickers are not steps.
function snapshot() {
  return { notation: state.notation, tl: timelineParam(), fps: editor.fps };
}

// Records the present state as a step when it differs from the last one recorded.
function checkpoint() {
  const now = snapshot();
  const last = state.current;
  if (last && last.notation === now.notation && last.tl === now.tl && last.fps === now.fps) return;
  if (last) state.history.push(last);
  state.current = now;
  state.future = [];
}

function restore(step) {
  state.current = step;
  editor.fps = step.fps;
  loadTimelineParam(step.tl, true);
  $("notation").value = step.notation;
  setNotation(step.notation, false, true);
  if (editor.tracks.length) timelineChanged();
}

function undo() {
  checkpoint(); // a change not yet recorded (a field still being typed in) is undone first
  if (!state.history.length) return;
  state.future.push(state.current);
  restore(state.history.pop());
}

function redo() {
  if (!state.future.length) return;
  state.history.push(state.current);
  restore(state.future.pop());
}

// ---- URL --------------------------------------------------------------------------------

// Backdrop, light and black-and-white, as the render API takes them.
function look() {
  return { backdrop: $("backdrop").value, light: $("light").value, grayscale: $("grayscale").checked };
}

function saveUrl() {
  const params = new URLSearchParams({ e: state.notation, p: state.identity, s: state.size });
  const { backdrop, light, grayscale } = look();
  if (backdrop !== "grey") params.set("b", backdrop);
  if (light !== "studio") params.set("l", light);
  if (grayscale) params.set("g", "1");
  const compare = $("compare-identity").value;
  if (compare) params.set("c", compare);
  if ($("show-neutral").checked) params.set("n", "1");
  if (editor.tracks.length) params.set("tl", timelineParam());
  if (editor.tracks.length && editor.fps !== state.catalog.clip.fps) params.set("fps", String(editor.fps));
  history.replaceState(null, "", "#" + params.toString());
}

function loadUrl() {
  const params = new URLSearchParams(location.hash.slice(1));
  const people = state.catalog.people.map((p) => p.id);
  if (people.includes(params.get("p"))) state.identity = params.get("p");
  if ([...$("size").options].some((o) => o.value === params.get("s"))) state.size = params.get("s");
  if (people.includes(params.get("c"))) $("compare-identity").value = params.get("c");
  $("show-neutral").checked = params.get("n") === "1";
  for (const [id, key] of [["backdrop", "b"], ["light", "l"]]) {
    if ([...$(id).options].some((o) => o.value === params.get(key))) $(id).value = params.get(key);
  }
  $("grayscale").checked = params.get("g") === "1";
  $("identity").value = state.identity;
  $("size").value = state.size;
  const fps = Number(params.get("fps"));
  editor.fps = Number.isInteger(fps) && fps >= 1 && fps <= 120 ? fps : state.catalog.clip.fps;
  loadTimelineParam(params.get("tl"), true);
  return params.get("e") || "0";
}

// ---- preview ----------------------------------------------------------------------------

function schedulePreview() {
  clearTimeout(state.timer);
  state.timer = setTimeout(preview, 60);
}

async function renderPng(body, signal) {
  const response = await fetch("api/v1/render", {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify(body),
    signal,
  });
  if (!response.ok) {
    const err = await response.json().catch(() => ({ error: response.statusText }));
    throw Object.assign(new Error(err.error), err);
  }
  return response.blob();
}

// Renders `body` and puts it in the main picture unless a newer picture was asked for meanwhile
// (a new request cancels the one under way, stills and timeline frames alike). Resolves to true
// when shown, false when overtaken, or the refusal ({error, field, …}) when the server refused.
async function showImage(body, caption, mark) {
  const id = ++state.requested;
  if (state.inflight) state.inflight.abort();
  const controller = new AbortController();
  state.inflight = controller;
  const started = performance.now();
  $("status").textContent = "rendering…";
  try {
    const blob = await renderPng(body, controller.signal);
    if (id < state.shown) return false; // an older picture never replaces a newer one
    state.shown = id;
    const url = URL.createObjectURL(blob);
    const img = $("image");
    if (img.src.startsWith("blob:")) URL.revokeObjectURL(img.src);
    img.src = url;
    img.dataset.request = String(id);
    delete img.dataset.frame;
    mark(img, url);
    $("caption").textContent = caption;
    $("status").textContent = `rendered in ${Math.round(performance.now() - started)} ms`;
    return true;
  } catch (err) {
    if (err.name === "AbortError") return false;
    $("status").textContent = err.token === undefined ? err.message : "";
    return err;
  } finally {
    if (state.inflight === controller) state.inflight = null;
  }
}

async function preview() {
  const body = { expression: state.notation, identity: state.identity, size: state.size, ...look() };
  const shown = await showImage(body, `${body.identity}: ${body.expression}`, (img, url) => {
    img.dataset.expression = body.expression;
    $("download-png").href = url;
    $("download-png").download = `${body.identity}_${body.expression.replace(/[^0-9A-Za-z@.+]/g, "_")}.png`;
  });
  if (shown === true) previewCompare(body);
  else if (shown && shown.token !== undefined) showError({ token: shown.token, column: shown.column, error: shown.error });
}

async function previewCompare(body) {
  const other = $("compare-identity").value;
  const neutral = $("show-neutral").checked;
  $("view-compare").hidden = !other && !neutral;
  if (!other && !neutral) return;
  const request = { ...body, identity: other || body.identity, expression: other ? body.expression : "0" };
  try {
    const blob = await renderPng(request);
    const img = $("image-compare");
    if (img.src.startsWith("blob:")) URL.revokeObjectURL(img.src);
    img.src = URL.createObjectURL(blob);
    $("caption-compare").textContent = `${request.identity}: ${request.expression}`;
  } catch (err) {
    $("caption-compare").textContent = err.message;
  }
}

// ---- wiring -----------------------------------------------------------------------------

function wire() {
  $("notation").addEventListener("input", (e) => {
    const parsed = parseNotation(e.target.value);
    if (parsed.error) return showError(parsed);
    state.pose = parsed.pose;
    setNotation(e.target.value.trim() || "0", false, false);
  });
  $("notation").addEventListener("change", (e) => {
    if (!parseNotation(e.target.value).error) setNotation(e.target.value.trim() || "0", true, true);
  });
  $("identity").addEventListener("change", (e) => { state.identity = e.target.value; setNotation(state.notation, false, false); timelineChanged(true); });
  $("size").addEventListener("change", (e) => { state.size = e.target.value; setNotation(state.notation, false, false); timelineChanged(true); });
  $("preset").addEventListener("change", (e) => {
    if (!e.target.value) return;
    $("notation").value = e.target.value;
    setNotation(e.target.value, true, true);
    e.target.value = "";
  });
  $("search").addEventListener("input", (e) => {
    const q = e.target.value.trim().toLowerCase();
    for (const row of document.querySelectorAll(".au")) row.hidden = Boolean(q) && !row.dataset.search.includes(q);
  });
  $("neutral").addEventListener("click", () => { $("notation").value = "0"; setNotation("0", true, true); });
  $("undo").addEventListener("click", undo);
  $("redo").addEventListener("click", redo);
  $("show-neutral").addEventListener("change", () => setNotation(state.notation, false, false));
  for (const id of ["backdrop", "light", "grayscale"]) $(id).addEventListener("change", () => setNotation(state.notation, false, false));
  $("compare-identity").addEventListener("change", () => setNotation(state.notation, false, false));
  $("copy-link").addEventListener("click", () => navigator.clipboard && navigator.clipboard.writeText(location.href));
  window.addEventListener("hashchange", () => {
    const notation = loadUrl();
    $("notation").value = notation;
    setNotation(notation, true, true);
  });
  document.addEventListener("keydown", (e) => {
    const typing = ["INPUT", "TEXTAREA", "SELECT"].includes(document.activeElement.tagName);
    if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === "z" && !typing) { e.preventDefault(); e.shiftKey ? redo() : undo(); }
    if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === "y" && !typing) { e.preventDefault(); redo(); }
    if (e.key === "/" && !typing) { e.preventDefault(); $("search").focus(); }
    if (e.key === " " && !typing && !document.activeElement.closest("button, a, .handle") && editor.tracks.length) { e.preventDefault(); play(); }
  });
}

async function start() {
  state.catalog = await (await fetch("api/v1/catalog")).json();
  for (const person of state.catalog.people) {
    for (const select of [$("identity"), $("compare-identity")]) {
      select.append(new Option(`${person.id} — ${person.description}`, person.id));
    }
  }
  for (const preset of state.catalog.presets) $("preset").append(new Option(`${preset.label} (${preset.expression})`, preset.expression));
  state.identity = state.catalog.defaults.identity;
  buildSliders();
  wire();
  wireTimeline();
  const notation = loadUrl();
  $("notation").value = notation;
  setNotation(notation, false, true);
  checkpoint();
  document.body.dataset.ready = "1";
}

start();
