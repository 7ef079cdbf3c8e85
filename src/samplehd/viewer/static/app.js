// samplehd viewer: a hash-routed single page over the read-only JSON API of `samplehd view`.
//   #/                    scene grid with filters (#/?family=stack&colour=red&page=2)
//   #/scene/<i>           one scene: RGB / depth / segmentation, annotation of the object under the cursor
//   #/instruction/<j>     one instruction: text, family, programs (tree + flat), targets outlined
//   #/episodes            episode list;  #/episode/<name>  the episode player;  #/dataset  info and file states
import {COLOUR_CSS, el, fill, getJSON, getPixels, HttpError, num, parseHash, rgb, swatch} from "./util.js";
import {drawMasks, idAt} from "./masks.js";
import {flatTokens, programTree} from "./tree.js";
import {openPlayer} from "./player.js";

const FILTERS = [["family", "family"], ["class", "class"], ["colour", "colour"], ["material", "material"],
  ["split", "split"], ["success", "episode outcome"]];
const PAGE = 60;
const MOVED = [255, 120, 0];
const REFERENCE = [0, 170, 255];

const view = document.getElementById("view");
let cleanup = () => {};
let status = null;
let shownCounts = null;  // the counts when the current page was drawn

// ---------------------------------------------------------------- status banner (polled: datasets grow)
// A dataset being written grows. A list page is not redrawn under the user's eyes: it says how many
// new items arrived and redraws (keeping filters and scroll position) when the user asks.
async function refreshStatus() {
  try {
    status = await getJSON("/api/status");
  } catch (err) {
    showBanner([`cannot reach the viewer server: ${err.message}`]);
    return;
  }
  document.getElementById("dataset-name").textContent = status.name;
  const c = status.counts;
  if (shownCounts === null) shownCounts = {...c};
  showNewItems();
  document.getElementById("counts").textContent =
    `${c.scenes} scenes · ${c.instructions} instructions · ${c.episodes} episodes`;
  const damaged = status.files.filter((f) => f.state === "damaged").map((f) => `${f.name}: ${f.detail}`);
  const notes = status.files
    .filter((f) => f.state === "partial" || (f.state === "missing" && f.name !== "info.json" && f.name !== "episodes"))
    .map((f) => `${f.name}: ${f.state} — ${f.detail}`);
  showBanner(damaged.length ? ["This dataset is damaged:", ...damaged, ...notes]
    : notes.length ? ["This dataset is incomplete or still being written:", ...notes] : []);
}

/** On a list page, "N new scenes — refresh" once the dataset has grown since the page was drawn. */
function showNewItems() {
  const notice = document.getElementById("new-items");
  if (!notice || !status || !shownCounts) return;
  const page = parseHash(location.hash).parts[0] || "scenes";
  const key = page === "scenes" ? "scenes" : page === "episodes" ? "episodes" : null;
  const grown = key ? status.counts[key] - shownCounts[key] : 0;
  notice.hidden = !(grown > 0);
  if (grown > 0) {
    notice.replaceChildren(el("button", {type: "button", id: "refresh-list", onclick: () => route({refresh: true})},
      `${grown} new ${grown === 1 ? key.replace(/s$/, "") : key} — refresh`));
  }
}

function showBanner(lines) {
  const banner = document.getElementById("banner");
  banner.replaceChildren();
  banner.hidden = lines.length === 0;
  if (lines.length) banner.append(el("strong", {}, lines[0]), el("ul", {}, lines.slice(1).map((l) => el("li", {}, l))));
}

// ---------------------------------------------------------------- routing
// Each navigation gets a number; a page is drawn off-screen and shown only if the user is still on
// it when its answers arrive (a slow answer for a page the user has left is dropped).
let routeNumber = 0;

async function route({refresh = false} = {}) {
  const number = ++routeNumber;
  const hash = location.hash;
  const scrollY = window.scrollY;
  cleanup();
  cleanup = () => {};
  const {parts, query} = parseHash(hash);
  const page = parts[0] || "scenes";
  for (const a of document.querySelectorAll("[data-nav]")) {
    a.classList.toggle("active", a.dataset.nav === page || (a.dataset.nav === "scenes" && page === "scene")
      || (a.dataset.nav === "episodes" && page === "episode"));
  }
  if (!refresh) view.replaceChildren(el("p", {class: "muted"}, "loading…"));
  const counts = status ? {...status.counts} : null;
  const target = el("div", {class: "page"});
  let close = () => {};
  try {
    if (page === "scenes") await sceneGrid(target, query);
    else if (page === "scene") await scenePage(target, wholeNumber(parts[1], "scene"));
    else if (page === "instruction") await instructionPage(target, wholeNumber(parts[1], "instruction"));
    else if (page === "episodes") await episodeList(target, query);
    else if (page === "dataset") await datasetPage(target);
    else if (page === "episode") close = await openPlayer(target, parts[1]);
    else target.replaceChildren(el("p", {class: "error"}, `no page ${page}`));
  } catch (err) {
    const missing = err instanceof HttpError && (err.status === 404 || err.status === 503);
    target.replaceChildren(el("div", {class: missing ? "placeholder" : "error", "data-error": "1"}, err.message));
    if (!(err instanceof HttpError)) console.warn(err);
  }
  if (number !== routeNumber) {  // the user has gone elsewhere meanwhile
    close();
    return;
  }
  cleanup = close;
  if (counts) shownCounts = counts;
  if (page === "scenes" || page === "episodes") target.prepend(el("div", {class: "new-items", id: "new-items", hidden: true}));
  view.replaceChildren(target);
  showNewItems();
  const saved = refresh ? scrollY : Number(sessionStorage.getItem(`scroll:${hash}`) || 0);
  window.scrollTo(0, saved);
}

/** A page number from the address: a whole number ≥ 0, else an error saying so. */
function wholeNumber(text, what) {
  if (!/^\d+$/.test(text || "")) throw new HttpError(404, `no ${what} ${text ?? ""}: give a number from 0`);
  return Number(text);
}

// Where the user was on each page, so a reload (or coming back) keeps the scroll position.
let scrollSave = 0;
window.addEventListener("scroll", () => {
  clearTimeout(scrollSave);
  scrollSave = setTimeout(() => sessionStorage.setItem(`scroll:${location.hash}`, String(window.scrollY)), 150);
});

function setHash(parts, query = {}) {
  const q = new URLSearchParams(Object.entries(query).filter(([, v]) => v !== "" && v !== undefined));
  const text = `#/${parts.join("/")}${q.toString() ? `?${q}` : ""}`;
  if (location.hash !== text) location.hash = text;
}

/** Previous / next links of item ``i`` of ``total`` (null: unknown); the ends are shown disabled. */
function stepLinks(kind, i, total, prev, next) {
  const link = (k, label, rel) => (k >= 0 && (total === null || total === undefined || k < total)
    ? el("a", {href: `#/${kind}/${k}`, "data-step": rel}, label)
    : el("span", {class: "muted disabled", "data-step": rel, "aria-disabled": "true"}, label));
  return [link(i - 1, prev, "prev"), link(i + 1, next, "next")];
}

// ---------------------------------------------------------------- scene grid
async function sceneGrid(target, query) {
  const pageNo = Math.max(1, Number(query.page || 1));
  const criteria = Object.fromEntries(FILTERS.map(([k]) => [k, query[k] || ""]));
  const params = new URLSearchParams({...criteria, offset: (pageNo - 1) * PAGE, limit: PAGE});
  for (const [k, v] of [...params]) if (v === "") params.delete(k);
  const data = await getJSON(`/api/scenes?${params}`);
  const filters = el("div", {class: "filters", id: "filters"});
  for (const [key, label] of FILTERS) {
    const select = el("select", {name: key, "data-filter": key, onchange: (e) => {
      setHash([], {...criteria, [key]: e.target.value, page: ""});
    }}, el("option", {value: ""}, "any"), data.options[key].map((v) => el("option", {value: v}, v)));
    select.value = criteria[key];
    filters.append(el("label", {}, label, select));
  }
  filters.append(el("button", {type: "button", onclick: () => setHash([])}, "clear filters"));
  const from = data.matched ? data.offset + 1 : 0;
  const to = Math.min(data.offset + data.scenes.length, data.matched);
  const line = el("div", {class: "summary-line", id: "grid-summary"},
    `${data.matched} of ${data.total} scenes match` + (data.matched ? ` · showing ${from}–${to}` : ""));
  const grid = el("div", {class: "grid", id: "scene-grid"}, data.scenes.map(sceneCard));
  if (!data.scenes.length) {
    grid.append(el("div", {class: "placeholder"}, data.total ? "no scene matches these filters" : "no scenes written yet"));
  }
  const pages = Math.max(1, Math.ceil(data.matched / PAGE));
  const pager = el("div", {class: "pager"},
    el("button", {type: "button", disabled: pageNo <= 1, onclick: () => setHash([], {...criteria, page: pageNo - 1})}, "‹ prev"),
    el("span", {}, `page ${pageNo} / ${pages}`),
    el("button", {type: "button", disabled: pageNo >= pages, onclick: () => setHash([], {...criteria, page: pageNo + 1})}, "next ›"));
  target.replaceChildren(el("h1", {}, "Scenes"), filters, line, grid, pager);
}

function sceneCard(s) {
  const outcome = s.success.includes("failure") ? el("span", {class: "chip bad"}, "has failures")
    : s.success.includes("success") ? el("span", {class: "chip ok"}, "success") : null;
  return el("a", {class: "card", href: `#/scene/${s.index}`, "data-scene": s.index},
    s.has_image === false ? el("div", {class: "placeholder thumb"}, "image not written yet")
      : el("img", {src: `/api/scenes/${s.index}/thumb`, loading: "lazy", alt: s.stem}),
    el("div", {class: "body"},
      el("div", {class: "title"}, el("span", {}, s.stem), el("span", {class: "muted"}, s.split.join(","))),
      el("div", {class: "muted"}, `${s.num_objects} objects · ${s.num_instructions} instructions · ${s.num_episodes} episodes`),
      el("div", {class: "chips"}, s.family.map((f) => el("span", {class: "chip fam"}, f)), outcome),
      el("div", {class: "muted", title: s.objects.join(", ")}, s.objects.join(", "))));
}

// ---------------------------------------------------------------- image stage with masks
/** An image with an overlay canvas; loads ids lazily for masks and the cursor read-out. */
function imageStage(sceneIndex, modality, written = true) {
  const img = el("img", {src: written ? `/api/scenes/${sceneIndex}/image/${modality}` : null, alt: `${modality} image`,
    id: "scene-image"});
  const overlay = el("canvas", {class: "overlay", id: "overlay"});
  const root = written ? el("div", {class: "stage crosshair"}, img, overlay)
    : el("div", {class: "placeholder"}, `${modality} image not written yet`);
  img.addEventListener("error", () => {
    root.replaceChildren(el("div", {class: "placeholder"}, `${modality} image not written yet`));
  });
  const stage = {
    root, img, overlay, ids: null, depth: null,
    setModality(m) { img.src = `/api/scenes/${sceneIndex}/image/${m}`; },
    async loadIds() {
      if (!stage.ids) {
        try { stage.ids = await getPixels(`/api/scenes/${sceneIndex}/ids`); } catch (_) { stage.ids = null; }
      }
      return stage.ids;
    },
    async loadDepth() {
      if (!stage.depth) {
        try { stage.depth = await getPixels(`/api/scenes/${sceneIndex}/depth_mm`); } catch (_) { stage.depth = null; }
      }
      return stage.depth;
    },
  };
  return stage;
}

function modalityToggle(onChange, available = {}) {
  const box = el("div", {class: "toggle", role: "group", "aria-label": "image modality"});
  for (const m of ["rgb", "depth", "segmentation"]) {
    const b = el("button", {type: "button", "data-modality": m, disabled: available[m] === false,
      title: available[m] === false ? "not written yet" : m}, m === "rgb" ? "RGB" : m[0].toUpperCase() + m.slice(1));
    b.addEventListener("click", () => {
      for (const x of box.children) x.classList.toggle("active", x === b);
      onChange(m);
    });
    if (m === "rgb") b.classList.add("active");
    box.append(b);
  }
  return box;
}

function kv(rows) {
  return el("table", {class: "kv"}, rows.filter(Boolean).map(([k, v]) => el("tr", {}, el("th", {}, k), el("td", {}, v))));
}

function describeObject(o) {
  return `${o.size || ""} ${o.colour || o.color || ""} ${o.material || ""} ${o.name || o.shape || ""}`.replace(/\s+/g, " ").trim();
}

function objectRows(o, index) {
  const c = o["3d_coords"] || [];
  const px = o.pixel_coords || [];
  const aff = Object.entries(o.affordances || {}).filter(([, v]) => v).map(([k]) => k).join(", ");
  return [
    ["object", `#${index} ${o.name || o.shape}${o.variant ? ` (${o.variant})` : ""}`],
    ["colour", el("span", {}, swatch(COLOUR_CSS[o.colour || o.color] || "#ccc"), o.colour || o.color)],
    ["material", o.material], ["size", o.size],
    o.weight && ["weight", `${o.weight}${o.mass ? ` (${num(o.mass, 3)} kg)` : ""}`],
    ["table part", (o.table_part || []).join(", ") || "neutral band"],
    ["3d coords [m]", c.map((v) => num(v, 3)).join(", ")],
    o.rotation !== undefined && ["rotation [°]", num(o.rotation, 1)],
    ["pixel coords", px.length ? `${px[0]}, ${px[1]} (depth ${num(px[2], 3)} m)` : "–"],
    o.bbox && ["extents [m]", (o.bbox.extents || []).map((v) => num(v, 3)).join(" × ")],
    aff && ["affordances", aff],
    ["segmentation id", String(o.segmentation_id ?? "")],
  ];
}

/** Rows "left of it: #2 pan, ..." from CLEVR relationships (relationships[r][i] = objects in direction r of i). */
function relationRows(relationships, k, objects) {
  const label = {left: "to its left", right: "to its right", front: "in front of it", behind: "behind it"};
  return Object.entries(relationships || {}).filter(([r]) => label[r]).map(([r, lists]) => {
    const others = (lists[k] || []).map((j) => `#${j} ${(objects[j] || {}).name || ""}`);
    return [label[r], others.join(", ") || "–"];
  });
}

/** A colour bar with the near/far depth of the shown range (1st/99th percentile, like the server). */
async function depthBar(stage) {
  const depth = await stage.loadDepth();
  const bar = el("canvas", {width: 160, height: 10});
  const ctx = bar.getContext("2d");
  const stops = [[48, 18, 59], [70, 107, 227], [40, 187, 236], [49, 242, 153], [162, 252, 60], [237, 208, 58],
    [251, 128, 34], [208, 47, 5], [122, 4, 3]].reverse();
  const grad = ctx.createLinearGradient(0, 0, 160, 0);
  stops.forEach((c, n) => grad.addColorStop(n / (stops.length - 1), rgb(c)));
  ctx.fillStyle = grad;
  ctx.fillRect(0, 0, 160, 10);
  if (!depth) return el("span", {class: "depth-bar"}, "depth not written yet");
  const valid = Array.from(depth.data).filter((v) => v > 0).sort((a, b) => a - b);
  const at = (q) => (valid.length ? valid[Math.min(valid.length - 1, Math.floor(q * valid.length))] / 1000 : 0);
  return el("span", {class: "depth-bar", id: "depth-bar"}, `near ${num(at(0.01), 2)} m`, bar, `far ${num(at(0.99), 2)} m`);
}

/** Chips linking an instruction's episodes and naming its rejected paths. */
function outcomeChips(q) {
  return [
    ...(q.episodes || []).map((e) => el("a", {href: `#/episode/${e.episode}`, class: `chip ${e.success ? "ok" : "bad"}`},
      e.success ? `episode ${e.episode} ✓` : `episode ${e.episode} ✗ ${e.failure_reason || ""}`)),
    ...(q.rejections || []).map((r) => el("span", {class: "chip bad", title: r.message}, `path rejected: ${r.reason}`)),
  ];
}

// ---------------------------------------------------------------- scene page
async function scenePage(target, i) {
  const data = await getJSON(`/api/scenes/${i}`);
  const scene = data.scene;
  const objects = scene.objects || [];
  const offset = data.segmentation_offset;
  const stage = imageStage(i, "rgb", data.images.rgb !== false);
  const barSlot = el("span");
  const hoverCard = el("div", {class: "panel hover-card", id: "hover-card"},
    el("p", {class: "muted"}, "Move the cursor over the image to see the annotation of the object under it."));
  const objectTable = el("table", {class: "objects", id: "object-table"},
    el("tr", {}, ["#", "object", "colour", "material", "size", "table part"].map((h) => el("th", {}, h))),
    objects.map((o, k) => el("tr", {"data-object": k},
      el("td", {}, swatch(rgb(data.object_colours[k])), String(k)), el("td", {}, o.name || o.shape),
      el("td", {}, swatch(COLOUR_CSS[o.colour || o.color] || "#ccc"), o.colour || o.color),
      el("td", {}, o.material), el("td", {}, o.size), el("td", {}, (o.table_part || []).join(", ")))));
  let hot = -2;
  const highlight = async (k) => {
    if (k === hot) return;
    hot = k;
    for (const tr of objectTable.querySelectorAll("tr[data-object]")) tr.classList.toggle("hot", Number(tr.dataset.object) === k);
    const ids = await stage.loadIds();
    if (!ids) return;
    drawMasks(stage.overlay, ids, k >= 0 ? [{ids: [k + offset], colour: [255, 230, 0], fill: 0.18}] : []);
  };
  const names = {0: "background", 1: "table", 2: "robot"};
  stage.root.addEventListener("mousemove", async (event) => {
    const ids = await stage.loadIds();
    if (!ids) { hoverCard.replaceChildren(el("p", {class: "muted"}, "segmentation not written yet")); return; }
    const hit = idAt(event, stage.img, ids);
    if (hit.id < 0) return;
    const depth = await stage.loadDepth();
    const mm = depth && hit.p >= 0 ? depth.data[hit.p] : 0;
    const where = el("p", {class: "muted mono"}, `pixel (${hit.x}, ${hit.y}) · id ${hit.id} · depth ${mm ? num(mm / 1000, 3) + " m" : "–"}`);
    const k = hit.id - offset;
    if (k >= 0 && k < objects.length) {
      hoverCard.replaceChildren(el("h2", {}, describeObject(objects[k])), kv([...objectRows(objects[k], k),
        ...relationRows(scene.relationships, k, objects)]), where);
    } else {
      hoverCard.replaceChildren(el("h2", {}, names[hit.id] || `id ${hit.id}`), where);
    }
    highlight(k >= 0 && k < objects.length ? k : -1);
  });
  stage.root.addEventListener("mouseleave", () => highlight(-1));
  objectTable.addEventListener("mouseover", (e) => {
    const tr = e.target.closest("tr[data-object]");
    if (tr) highlight(Number(tr.dataset.object));
  });

  const instructions = el("ul", {class: "instr-list", id: "instruction-list"}, data.instructions.map((q) => el("li", {},
    el("a", {href: `#/instruction/${q.instruction_index}`}, q.instruction || q.question || `instruction ${q.instruction_index}`),
    el("div", {class: "chips"}, el("span", {class: "chip fam"}, q.family || "?"),
      el("span", {class: "chip"}, q.template_name || q.template_filename || ""), outcomeChips(q)))));
  const cam = scene.camera || {};
  const man = scene.manipulator || {};
  const meta = kv([
    ["split", scene.split], ["image", scene.image_filename], ["seed", String(scene.seed ?? "–")],
    cam.pos && ["camera position [m]", cam.pos.map((v) => num(v, 3)).join(", ")],
    cam.fovy && ["camera fovy [°]", num(cam.fovy, 1)],
    man.joint_positions && ["arm joints [rad]", man.joint_positions.map((v) => num(v, 2)).join(", ")],
    man.tcp_position && ["TCP [m]", man.tcp_position.map((v) => num(v, 3)).join(", ")],
  ]);
  const nav = el("div", {class: "toolbar"},
    ...stepLinks("scene", i, status && status.counts.scenes, "‹ previous scene", "next scene ›"),
    el("a", {href: `/files/scenes/${encodeURIComponent((scene.image_filename || "").replace(/\.png$/, ".json"))}`,
      target: "_blank"}, "scene JSON"));
  fill(target,
    el("h1", {}, `Scene ${i} — ${(scene.image_filename || "").replace(/\.png$/, "")}`), nav,
    el("div", {class: "row"},
      el("div", {class: "col-main"},
        el("div", {class: "toolbar"}, modalityToggle(async (m) => {
          stage.setModality(m);
          barSlot.replaceChildren(m === "depth" ? await depthBar(stage) : "");
        }, data.images), el("span", {class: "muted"}, `${objects.length} objects`), barSlot),
        stage.root,
        el("h3", {}, "Objects"), objectTable),
      el("div", {class: "col-side"}, hoverCard,
        el("h3", {}, `Instructions (${data.instructions.length})`),
        data.instructions.length ? instructions : el("p", {class: "muted"}, "no instructions for this scene (yet)"),
        data.rejections.length ? el("h3", {}, `Rejected paths (${data.rejections.length})`) : null,
        data.rejections.length ? el("ul", {class: "instr-list", id: "rejection-list"}, data.rejections.map((r) => el("li", {},
          r.instruction_index !== null ? el("a", {href: `#/instruction/${r.instruction_index}`}, r.instruction)
            : el("span", {}, r.instruction || `slot ${r.slot}`),
          el("div", {class: "chips"}, el("span", {class: "chip fam"}, r.family || "?"),
            el("span", {class: "chip bad"}, r.reason)), el("div", {class: "muted"}, r.message)))) : null,
        el("h3", {}, "Scene"), meta)));
}

// ---------------------------------------------------------------- instruction page
function targetGroups(q, offset) {
  const task = q.task || {};
  const moved = Array.isArray(task.objects) ? task.objects : (q.targets || []);
  const reference = Number.isInteger(task.subject) ? [task.subject] : [];
  const others = (q.targets || []).filter((t) => !moved.includes(t) && !reference.includes(t));
  return {
    moved, reference: [...reference, ...others],
    groups: [
      {ids: moved.map((k) => k + offset), colour: MOVED, fill: 0.3},
      {ids: [...reference, ...others].map((k) => k + offset), colour: REFERENCE, fill: 0.3},
    ],
  };
}

async function instructionPage(target, j) {
  const data = await getJSON(`/api/instructions/${j}`);
  const q = data.instruction;
  const scene = data.scene;
  const objects = (scene && scene.objects) || [];
  const sceneIndex = q.image_index;
  const {moved, reference, groups} = targetGroups(q, data.segmentation_offset);
  const name = (k) => (objects[k] ? `#${k} ${describeObject(objects[k])}` : `#${k}`);
  let imageBlock;
  if (scene) {
    const stage = imageStage(sceneIndex, "rgb", data.image_written);
    stage.root.classList.remove("crosshair");
    stage.loadIds().then((ids) => { if (ids) drawMasks(stage.overlay, ids, groups, 3); });
    imageBlock = el("div", {}, el("div", {class: "toolbar"}, modalityToggle((m) => stage.setModality(m))), stage.root,
      el("div", {class: "legend", id: "target-legend"},
        ...legend(moved, MOVED, "moved", name), ...legend(reference, REFERENCE, "reference", name)));
  } else {
    imageBlock = el("div", {class: "placeholder"}, `scene ${sceneIndex} not written yet`);
  }
  const episodes = [
    ...data.episodes.map((e) => el("a", {href: `#/episode/${e.episode}`, class: `chip ${e.success ? "ok" : "bad"}`},
      `episode ${e.episode}: ${e.success ? "success" : `failure ${e.failure_reason || ""}`}`
      + (e.num_frames >= 0 ? ` · ${e.num_frames} frames` : ""))),
    ...data.rejections.map((r) => el("span", {class: "chip bad", title: r.message}, `path rejected: ${r.reason} — ${r.message}`)),
  ];
  fill(target,
    el("h1", {}, `Instruction ${j}`),
    el("div", {class: "toolbar"},
      ...stepLinks("instruction", j, status && status.counts.instructions, "‹ previous", "next ›"),
      el("a", {href: `#/scene/${sceneIndex}`}, `scene ${sceneIndex}`)),
    el("div", {class: "row"},
      el("div", {class: "col-main"}, imageBlock),
      el("div", {class: "col-side"},
        el("div", {class: "instr-text", id: "instruction-text"}, `“${q.instruction || q.question || ""}”`),
        el("div", {class: "chips"}, el("span", {class: "chip fam", id: "instruction-family"}, q.family || "?"),
          el("span", {class: "chip"}, `template ${q.template_name || q.template_filename || "?"}`),
          el("span", {class: "chip"}, q.split || "")),
        el("h3", {}, "Targets"),
        kv([["moved", moved.map(name).join("; ") || "–"], ["reference", reference.map(name).join("; ") || "–"],
          q.task && ["task", `${q.task.type}${q.task.subject !== null && q.task.subject !== undefined ? ` → ${q.task.subject}` : ""}`
            + `${q.task.relation ? ` (${q.task.relation})` : ""}`]]),
        el("h3", {}, "Episodes"), episodes.length ? el("div", {class: "chips"}, episodes) : el("p", {class: "muted"}, "no episode recorded"),
        el("h3", {}, "Program (flat, SAMPLE-HD)"), el("div", {id: "flat-program"}, flatTokens(q.program_sequence)),
        el("h3", {}, "Program (CLEVR nodes, as a tree)"), el("div", {class: "tree-wrap", id: "program-tree"}, programTree(q.program)))),
    el("h3", {}, "Task"), el("pre", {class: "json"}, JSON.stringify({task: q.task, targets: q.targets, params: q.params}, null, 1)));
}

function legend(indices, colour, label, name) {
  if (!indices.length) return [];
  const line = el("span", {class: "line"});
  line.style.borderTopColor = rgb(colour);
  return [el("span", {}, line, `${label}: ${indices.map(name).join("; ")}`)];
}

// ---------------------------------------------------------------- episode list
async function episodeList(target, query) {
  const params = new URLSearchParams(Object.entries({family: query.family || "", success: query.success || ""})
    .filter(([, v]) => v));
  const data = await getJSON(`/api/episodes?${params}`);
  const all = await getJSON("/api/episodes");
  const families = [...new Set(all.episodes.map((e) => e.family))].sort();
  const pick = (key, values) => {
    const s = el("select", {"data-filter": key, onchange: (e) => setHash(["episodes"], {...query, [key]: e.target.value})},
      el("option", {value: ""}, "any"), values.map((v) => el("option", {value: v}, v)));
    s.value = query[key] || "";
    return el("label", {}, key, s);
  };
  const rows = data.episodes.map((e) => el("tr", {},
    el("td", {}, el("a", {href: `#/episode/${e.episode}`}, String(e.episode))),
    el("td", {}, el("a", {href: `#/scene/${e.scene_index}`}, String(e.scene_index))),
    el("td", {}, el("a", {href: `#/instruction/${e.instruction_index}`}, e.instruction || String(e.instruction_index))),
    el("td", {}, e.family), el("td", {}, e.num_frames >= 0 ? String(e.num_frames) : "?"),
    el("td", {}, el("span", {class: `chip ${e.success ? "ok" : "bad"}`}, e.success ? "success" : `failure ${e.failure_reason || ""}`))));
  const rejected = data.rejections.map((r) => el("tr", {},
    el("td", {}, el("a", {href: `#/scene/${r.scene_index}`}, String(r.scene_index))), el("td", {}, String(r.slot)),
    el("td", {}, r.instruction_index !== null && r.instruction_index !== undefined
      ? el("a", {href: `#/instruction/${r.instruction_index}`}, r.instruction || String(r.instruction_index)) : "–"),
    el("td", {}, r.family || ""), el("td", {}, el("span", {class: "chip bad"}, r.reason)), el("td", {class: "muted"}, r.message)));
  const reasons = {};
  for (const r of data.rejections) reasons[r.reason] = (reasons[r.reason] || 0) + 1;
  const filtered = Boolean(query.family || query.success);
  const empty = !rows.length ? el("div", {class: "placeholder", id: "episodes-empty"},
    filtered && all.episodes.length ? `no episode matches these filters (${all.episodes.length} episodes in all)`
      : data.state.state === "ok" ? "this dataset has no episodes" : "no episodes written yet") : null;
  fill(target, el("h1", {}, "Episodes"),
    el("div", {class: "filters"}, pick("family", families), pick("success", ["success", "failure"]),
      filtered ? el("button", {type: "button", onclick: () => setHash(["episodes"])}, "clear filters") : null),
    el("div", {class: "summary-line", id: "episode-summary"},
      `${data.episodes.length} of ${all.episodes.length} episodes match`),
    data.state.state !== "ok" ? el("p", {class: "muted"}, data.state.detail) : null,
    rows.length ? el("table", {class: "objects", id: "episode-table"},
      el("tr", {}, ["episode", "scene", "instruction", "family", "frames", "outcome"].map((h) => el("th", {}, h))), rows)
      : empty,
    data.rejections.length ? el("h2", {}, `Rejected paths (${data.rejections.length}): `
      + Object.entries(reasons).sort((a, b) => b[1] - a[1]).map(([k, v]) => `${k} ${v}`).join(", ")) : null,
    data.rejections.length ? el("table", {class: "objects", id: "rejection-table"},
      el("tr", {}, ["scene", "slot", "instruction", "family", "reason", "message"].map((h) => el("th", {}, h))), rejected) : null);
}

// ---------------------------------------------------------------- dataset page
async function datasetPage(target) {
  const st = await getJSON("/api/status");
  const info = st.info || {};
  const versions = info.versions || {};
  fill(target, el("h1", {}, `Dataset ${st.name}`),
    kv([["folder", st.root], ["status", info.status || "–"], ["format version", info.format_version || "–"],
      ...Object.entries(versions).map(([k, v]) => [`${k} version`, String(v)]),
      ...Object.entries(st.counts).map(([k, v]) => [k, String(v)])]),
    el("h3", {}, "Files"),
    el("table", {class: "objects", id: "file-states"}, el("tr", {}, ["file", "state", "detail"].map((h) => el("th", {}, h))),
      st.files.map((f) => el("tr", {}, el("td", {}, f.name),
        el("td", {}, el("span", {class: `chip ${f.state === "ok" ? "ok" : "bad"}`}, f.state)), el("td", {class: "muted"}, f.detail)))),
    el("h3", {}, "info.json"), el("pre", {class: "json", id: "info-json"}, JSON.stringify(info, null, 1)));
}

// ---------------------------------------------------------------- start
window.addEventListener("hashchange", route);
refreshStatus().then(route);
setInterval(refreshStatus, 5000);
