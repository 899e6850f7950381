// The demo page: start a query, then follow its server-sent events (status, program, call, frame,
// answer, error, done). Plain JavaScript, no build step.
"use strict";

const $ = (id) => document.getElementById(id);
let source = null;

function setStatus(text, kind) {
  const el = $("status");
  el.textContent = text;
  el.className = "status" + (kind ? " " + kind : "");
}

function short(value) {
  // an API call's argument or result, as a person reads it
  if (value === null || value === undefined) return "None";
  if (Array.isArray(value)) return "[" + value.map(short).join(", ") + "]";
  if (typeof value === "object") {
    if (value.type === "ImagePatch") return value.object_id || value.label || "patch";
    if (value.type) return value.type;
    return JSON.stringify(value);
  }
  if (typeof value === "number") return Number.isInteger(value) ? String(value) : value.toFixed(3);
  return JSON.stringify(value);
}

function addCall(call) {
  const li = document.createElement("li");
  const name = document.createElement("code");
  name.textContent = call.call + "(" + (call.args || []).map(short).join(", ") + ")";
  li.appendChild(name);
  const result = document.createElement("span");
  if (call.error) {
    result.className = "call-error";
    result.textContent = " failed: " + call.error;
  } else {
    result.className = "call-result";
    result.textContent = " \u2192 " + short(call.result);
  }
  li.appendChild(result);
  const ms = document.createElement("span");
  ms.className = "ms";
  ms.textContent = " " + Math.round(call.ms) + " ms" + (call.line ? ", line " + call.line : "");
  li.appendChild(ms);
  $("calls").appendChild(li);
  li.scrollIntoView({ block: "nearest" });
}

function showAnswer(event) {
  const a = event.answer;
  $("result").hidden = false;
  $("answer-text").textContent = a.answer;
  $("answer-text").className = "answer-text" + (a.error ? " failed" : "");
  $("answer-json").textContent = JSON.stringify(a, null, 2);
  const rows = [];
  if (a.object) rows.push(["object", (a.object.category || "object") + (a.object.id ? " (" + a.object.id + ")" : "")]);
  if (a.object) rows.push(["box", "[" + a.object.box.map((v) => Math.round(v)).join(", ") + "] px"]);
  if (a.value !== null && a.value !== undefined) rows.push(["value", a.value.toFixed(3) + " " + (a.unit || "")]);
  if (a.boolean !== null && a.boolean !== undefined) rows.push(["yes/no", a.boolean ? "yes" : "no"]);
  for (const t of a.trace || []) {
    if (t.call.startsWith("Robot.measure_") && !t.error) {
      const what = t.call === "Robot.measure_weight" ? "weight" : "distance";
      const unit = what === "weight" ? "kg" : "m";
      rows.push([what + " of " + short(t.args[0]), short(t.result) + " " + unit]);
    }
  }
  const prompt = a.prompt ? ", " + a.prompt + " prompt" : "";
  rows.push(["planner", a.planner + prompt + (a.attempts > 1 ? ", " + a.attempts + " tries" : "")]);
  rows.push(["backends", Object.entries(a.backends || {}).map(([k, v]) => k + "=" + v).join(", ")]);
  if (a.sim_s !== null && a.sim_s !== undefined) rows.push(["robot time", a.sim_s.toFixed(1) + " s (simulated)"]);
  const table = $("values");
  table.replaceChildren();
  for (const [k, v] of rows) {
    const tr = table.insertRow();
    const th = document.createElement("th");
    th.textContent = k;
    tr.appendChild(th);
    tr.insertCell().textContent = v;
  }
  if (event.image) {
    $("answer-image").src = event.image;
    $("answer-image").hidden = false;
  }
  for (const [id, url] of [["download-video", event.video], ["download-run", event.saved_run]]) {
    $(id).hidden = !url;
    if (url) $(id).href = url;
  }
}

function finish() {
  if (source) source.close();
  source = null;
  $("ask").disabled = false;
}

function follow(url) {
  source = new EventSource(url);
  let opened = 0;
  source.addEventListener("open", () => {
    // a reconnection replays the run from its start: show it once
    if (opened++ > 0) $("calls").replaceChildren();
  });
  source.addEventListener("status", (e) => setStatus(JSON.parse(e.data).text, "busy"));
  source.addEventListener("program", (e) => {
    const p = JSON.parse(e.data);
    $("program").textContent = (p.attempt > 1 ? "# try " + p.attempt + "\n" : "") + p.text;
  });
  source.addEventListener("call", (e) => addCall(JSON.parse(e.data)));
  source.addEventListener("frame", (e) => {
    const f = JSON.parse(e.data);
    $("robot-camera").src = f.robot;
    $("room-camera").src = f.room;
  });
  source.addEventListener("answer", (e) => {
    const event = JSON.parse(e.data);
    showAnswer(event);
    setStatus(event.answer.error ? "no answer" : "answered", event.answer.error ? "bad" : "good");
  });
  source.addEventListener("error", (e) => {
    if (!e.data) {  // the connection itself: EventSource would reconnect; the run is over or gone
      if (source && source.readyState === EventSource.CLOSED) finish();
      return;
    }
    const err = JSON.parse(e.data);
    setStatus("error: " + err.message + (err.fix ? " (fix: " + err.fix + ")" : ""), "bad");
  });
  source.addEventListener("done", finish);
}

function readFile(file) {
  // the image as {name, data: base64}, the way the server takes it
  return new Promise((resolve, reject) => {
    const reader = new FileReader();
    reader.onload = () => resolve({ name: file.name, data: String(reader.result).split(",", 2)[1] || "" });
    reader.onerror = () => reject(reader.error);
    reader.readAsDataURL(file);
  });
}

async function ask(event) {
  event.preventDefault();
  const form = new FormData($("ask-form"));
  const request = { query: form.get("query") };
  if (form.get("where") === "image") {
    const file = $("image").files[0];
    if (!file) {
      setStatus("choose an image first", "bad");
      return;
    }
    request.image = await readFile(file);
  } else {
    for (const name of ["layout", "seed", "objects", "options"]) request[name] = form.get(name);
  }
  $("ask").disabled = true;
  $("result").hidden = true;
  $("answer-image").hidden = true;
  $("calls").replaceChildren();
  $("program").textContent = "(planning)";
  setStatus("sending", "busy");
  let reply;
  try {
    // the page's own secret (the server wrote it into the page): another site cannot send it
    const secret = document.querySelector("meta[name=attribot-secret]").content;
    reply = await fetch("/api/runs", {
      method: "POST",
      headers: { "Content-Type": "application/json", "X-Attribot-Secret": secret },
      body: JSON.stringify(request),
    });
  } catch (e) {
    setStatus("the demo server cannot be reached: " + e, "bad");
    $("ask").disabled = false;
    return;
  }
  let body;
  try {
    body = await reply.json();
  } catch (e) {
    body = { message: "the demo answered " + reply.status + " " + reply.statusText, fix: null };
  }
  if (!reply.ok) {
    setStatus("error: " + body.message + (body.fix ? " (fix: " + body.fix + ")" : ""), "bad");
    $("ask").disabled = false;
    return;
  }
  follow(body.events);
}

async function loadOptions() {
  const reply = await fetch("/api/options");
  const o = await reply.json();
  const select = $("layout");
  for (const name of o.layouts) {
    const opt = document.createElement("option");
    opt.value = opt.textContent = name;
    if (name === "household") opt.selected = true;
    select.appendChild(opt);
  }
  $("query").maxLength = o.max_query_chars;
  const planner = o.planner === "llm"
    ? "an LLM (" + (o.llm_model || "model not set") + ", shown the " + o.prompt + " prompt)" : "the offline rules";
  $("backends").textContent = "Programs are written by " + planner + "; detector " + o.backends.detector +
    ", VQA " + o.backends.vqa + ", language " + o.backends.language + ".";
}

function init() {
  $("ask-form").addEventListener("submit", ask);
  for (const b of $("examples").querySelectorAll("button")) {
    b.addEventListener("click", () => { $("query").value = b.textContent; $("query").focus(); });
  }
  for (const r of document.querySelectorAll("input[name=where]")) {
    r.addEventListener("change", () => {
      const image = document.querySelector("input[name=where]:checked").value === "image";
      $("image-fields").hidden = !image;
      $("scene-fields").hidden = image;
    });
  }
  loadOptions().catch((e) => setStatus("cannot load the options: " + e, "bad"));
}

document.addEventListener("DOMContentLoaded", init);
