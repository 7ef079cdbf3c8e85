// Programs: the CLEVR node list drawn as an SVG tree (root = answer/task node at the top, `scene`
// leaves at the bottom) and the SAMPLE-HD flat token sequence as coloured tokens.
import {el} from "./util.js";

const KIND_FILL = {task: "#ffe6d5", scene: "#eeeeee", filter: "#e6f0ff", relate: "#efe3ff", set: "#e4f6e8"};
const KIND_STROKE = {task: "#d9822b", scene: "#999999", filter: "#5b8def", relate: "#8a5cd0", set: "#3c9d5d"};

/** Kind of a node type or flat token: task, scene, filter, relate or set. */
export function nodeKind(type) {
  if (type === "scene") return "scene";
  if (type.startsWith("relate") || type.startsWith("filter_relate")) return "relate";
  if (type.startsWith("filter")) return "filter";
  if (["unique", "union", "intersect"].includes(type)) return "set";
  return "task";
}

/**
 * Tree layout of a CLEVR program: {x, y} slot coordinates per node index.
 * Children are a node's inputs; roots are the nodes no other node uses (normally the last).
 */
export function layoutProgram(program) {
  const used = new Set(program.flatMap((n) => n.inputs || []));
  const roots = program.map((_, i) => i).filter((i) => !used.has(i));
  const pos = new Map();
  let nextSlot = 0;
  const place = (i, depth, trail) => {
    if (pos.has(i) || trail.has(i) || i < 0 || i >= program.length) return;
    trail.add(i);
    const inputs = (program[i].inputs || []).filter((j) => j >= 0 && j < program.length && !pos.has(j));
    for (const j of inputs) place(j, depth + 1, trail);
    trail.delete(i);
    const xs = (program[i].inputs || []).map((j) => pos.get(j)).filter(Boolean).map((p) => p.x);
    const x = xs.length ? (Math.min(...xs) + Math.max(...xs)) / 2 : nextSlot++;
    pos.set(i, {x, y: depth});
  };
  for (const r of roots) place(r, 0, new Set());
  program.forEach((_, i) => place(i, 0, new Set()));  // anything unreachable (malformed programs)
  return pos;
}

/** SVG element drawing a CLEVR program as a tree. */
export function programTree(program) {
  if (!Array.isArray(program) || program.length === 0) return el("p", {class: "muted"}, "no program");
  const pos = layoutProgram(program);
  const labels = program.map((n) => {
    const values = (n.value_inputs || []).join(", ");
    return {type: String(n.type), value: values ? `[${values}]` : ""};
  });
  const charW = 7.4;
  const boxW = Math.max(90, ...labels.map((l) => Math.max(l.type.length, l.value.length) * charW + 22));
  const boxH = 34;
  const gapX = 14;
  const gapY = 24;
  const slots = Math.max(...[...pos.values()].map((p) => p.x)) + 1;
  const depth = Math.max(...[...pos.values()].map((p) => p.y)) + 1;
  const width = slots * (boxW + gapX) + gapX;
  const height = depth * (boxH + gapY) + gapY - 10;
  const cx = (i) => gapX + pos.get(i).x * (boxW + gapX) + boxW / 2;
  const top = (i) => 12 + pos.get(i).y * (boxH + gapY);
  const svg = el("svg:svg", {class: "tree", width, height, viewBox: `0 0 ${width} ${height}`,
    role: "img", "aria-label": "program tree"});
  const defs = el("svg:defs", {},
    el("svg:marker", {id: "arrow", viewBox: "0 0 10 10", refX: 10, refY: 5, markerWidth: 7, markerHeight: 7,
      orient: "auto-start-reverse"}, el("svg:path", {d: "M 0 0 L 10 5 L 0 10 z", fill: "#888"})));
  svg.append(defs);
  // edges: from each input (below) up to the node that uses it
  program.forEach((n, i) => {
    for (const j of n.inputs || []) {
      if (!pos.has(j)) continue;
      const x1 = cx(j); const y1 = top(j);
      const x2 = cx(i); const y2 = top(i) + boxH;
      const my = (y1 + y2) / 2;
      svg.append(el("svg:path", {d: `M ${x1} ${y1} C ${x1} ${my}, ${x2} ${my}, ${x2} ${y2}`, fill: "none",
        stroke: "#888", "stroke-width": 1.4, "marker-end": "url(#arrow)"}));
    }
  });
  program.forEach((n, i) => {
    const kind = nodeKind(labels[i].type);
    const x = cx(i) - boxW / 2; const y = top(i);
    const g = el("svg:g", {class: `node kind-${kind}`, "data-index": i});
    g.append(el("svg:rect", {x, y, width: boxW, height: boxH, rx: 6, fill: KIND_FILL[kind], stroke: KIND_STROKE[kind],
      "stroke-width": 1.4}));
    g.append(el("svg:text", {x: x + 4, y: y + 10, "font-size": 9, fill: "#888"}, String(i)));
    g.append(el("svg:text", {x: cx(i), y: y + (labels[i].value ? 15 : 21), "text-anchor": "middle", fill: "#1d2127",
      "font-weight": 600}, labels[i].type));
    if (labels[i].value) {
      g.append(el("svg:text", {x: cx(i), y: y + 28, "text-anchor": "middle", fill: "#444"}, labels[i].value));
    }
    g.append(el("svg:title", {}, `node ${i}: ${labels[i].type}${labels[i].value} ← inputs [${(n.inputs || []).join(", ")}]`));
    svg.append(g);
  });
  return svg;
}

/** The flat program ("place[left] scene filter_colour[red] ...") as coloured tokens. */
export function flatTokens(sequence) {
  const tokens = Array.isArray(sequence) ? sequence : String(sequence || "").split(/\s+/).filter(Boolean);
  if (!tokens.length) return el("p", {class: "muted"}, "no flat program");
  return el("div", {class: "flat"}, tokens.map((t) => el("span", {class: `tok ${nodeKind(t.split("[")[0])}`}, t)));
}
