// Canvas charts drawn here (no chart library): line plots over frames and the subtask timeline,
// both with a frame cursor and click/drag to seek.
import {el} from "./util.js";

export const SERIES_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
  "#7f7f7f", "#bcbd22", "#17becf"];

const SUBTASK_COLOURS = {
  GripperMoveAvoid: "#8ecae6", ApproachGrasp: "#219ebc", CloseGripper: "#e76f51", MoveUP: "#f4a261",
  ObjectMove: "#2a9d8f", MoveDOWN: "#e9c46a", OpenGripper: "#b5838d", MoveToDefaultPos: "#adb5bd",
  Succeeded: "#52b788", Completed: "#52b788",
};

/** Colour of a subtask name (fixed for SAMPLE-HD's names, hashed for others). */
export function subtaskColour(name) {
  if (SUBTASK_COLOURS[name]) return SUBTASK_COLOURS[name];
  let h = 0;
  for (const c of String(name)) h = (h * 31 + c.charCodeAt(0)) >>> 0;
  return `hsl(${h % 360} 55% 65%)`;
}

function setupCanvas(canvas, cssHeight) {
  const ratio = window.devicePixelRatio || 1;
  const cssWidth = Math.max(200, canvas.clientWidth || canvas.parentElement.clientWidth || 600);
  canvas.style.height = `${cssHeight}px`;
  canvas.width = Math.round(cssWidth * ratio);
  canvas.height = Math.round(cssHeight * ratio);
  const ctx = canvas.getContext("2d");
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  return {ctx, width: cssWidth, height: cssHeight};
}

function seekOnPointer(canvas, left, right, frames, onSeek) {
  const seek = (event) => {
    const rect = canvas.getBoundingClientRect();
    const x = event.clientX - rect.left;
    const f = Math.round((x - left) / Math.max(1, rect.width - left - right) * (frames - 1));
    onSeek(Math.max(0, Math.min(frames - 1, f)));
  };
  canvas.addEventListener("pointerdown", (e) => { canvas.setPointerCapture(e.pointerId); seek(e); });
  canvas.addEventListener("pointermove", (e) => { if (e.buttons & 1) seek(e); });
}

function niceTicks(lo, hi, count = 5) {
  const span = hi - lo || 1;
  const step0 = span / count;
  const mag = 10 ** Math.floor(Math.log10(step0));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => span / s <= count) || step0;
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9; v += step) out.push(Math.abs(v) < 1e-12 ? 0 : v);
  return out;
}

/** A line plot of several series over frames with a frame cursor. */
export class LinePlot {
  /**
   * @param {{title:string, unit?:string, series:Array<{name:string, values:number[]}>, time:number[],
   *          range?:number[], height?:number, onSeek?:(frame:number)=>void}} options
   */
  constructor(options) {
    this.options = options;
    this.frame = 0;
    this.canvas = el("canvas", {"aria-label": options.title});
    this.root = el("div", {class: "plot"},
      el("div", {class: "legend"}, el("strong", {}, options.title + (options.unit ? ` [${options.unit}]` : "")),
        options.series.map((s, k) => el("span", {}, legendLine(s.colour || SERIES_COLOURS[k]), s.name))),
      this.canvas);
    this.margin = {left: 46, right: 10, top: 8, bottom: 20};
    if (options.onSeek) {
      seekOnPointer(this.canvas, this.margin.left, this.margin.right, options.time.length, options.onSeek);
    }
  }

  /** Draw (again) at the canvas' current width. */
  draw() {
    const {ctx, width, height} = setupCanvas(this.canvas, this.options.height || 150);
    const m = this.margin;
    const n = this.options.time.length;
    const values = this.options.series.flatMap((s) => s.values.filter((v) => Number.isFinite(v)));
    let [lo, hi] = this.options.range || [Math.min(...values), Math.max(...values)];
    if (!Number.isFinite(lo) || !Number.isFinite(hi)) [lo, hi] = [0, 1];
    if (hi - lo < 1e-9) { lo -= 0.5; hi += 0.5; }
    const pad = this.options.range ? 0 : (hi - lo) * 0.06;
    lo -= pad; hi += pad;
    const px = (f) => m.left + (n > 1 ? f / (n - 1) : 0) * (width - m.left - m.right);
    const py = (v) => m.top + (1 - (v - lo) / (hi - lo)) * (height - m.top - m.bottom);
    this.px = px;
    ctx.clearRect(0, 0, width, height);
    ctx.font = "10px system-ui, sans-serif";
    ctx.fillStyle = "#67707c";
    ctx.strokeStyle = "#eee";
    ctx.lineWidth = 1;
    for (const v of niceTicks(lo, hi, 4)) {
      ctx.beginPath(); ctx.moveTo(m.left, py(v)); ctx.lineTo(width - m.right, py(v)); ctx.stroke();
      ctx.textAlign = "right"; ctx.textBaseline = "middle";
      ctx.fillText(String(+v.toFixed(3)), m.left - 4, py(v));
    }
    const time = this.options.time;
    const t0 = time[0] || 0; const t1 = time[n - 1] || 1;
    ctx.textAlign = "center"; ctx.textBaseline = "top";
    for (const t of niceTicks(t0, t1, 8)) {
      const f = time.findIndex((x) => x >= t);
      if (f < 0) continue;
      ctx.fillText(`${+t.toFixed(2)} s`, px(f), height - m.bottom + 4);
    }
    ctx.strokeStyle = "#ccc";
    ctx.strokeRect(m.left, m.top, width - m.left - m.right, height - m.top - m.bottom);
    this.options.series.forEach((s, k) => {
      ctx.strokeStyle = s.colour || SERIES_COLOURS[k];
      ctx.lineWidth = 1.4;
      ctx.beginPath();
      let pen = false;
      s.values.forEach((v, f) => {
        if (!Number.isFinite(v)) { pen = false; return; }
        if (pen) ctx.lineTo(px(f), py(v)); else ctx.moveTo(px(f), py(v));
        pen = true;
      });
      ctx.stroke();
    });
    this.base = ctx.getImageData(0, 0, this.canvas.width, this.canvas.height);
    this.ctx = ctx;
    this.size = {width, height};
    this.setCursor(this.frame);
  }

  /** Move the frame cursor. */
  setCursor(frame) {
    this.frame = frame;
    if (!this.base) return;
    const {ctx} = this;
    ctx.putImageData(this.base, 0, 0);
    const x = this.px(frame);
    ctx.strokeStyle = "#d33"; ctx.lineWidth = 1.5;
    ctx.beginPath(); ctx.moveTo(x, this.margin.top); ctx.lineTo(x, this.size.height - this.margin.bottom); ctx.stroke();
  }
}

function legendLine(colour) {
  const span = el("span", {class: "line"});
  span.style.borderTopColor = colour;
  return span;
}

/** Subtask timeline: one coloured segment per run of equal subtask index, with a frame cursor; a
 * disturbed episode's bands (the disturbance in red, the recovery in green) run in a strip below. */
export class Timeline {
  /**
   * @param {{segments:Array<{start:number,end:number,name:string}>, frames:number,
   *          bands?:Array<{start:number,end:number,kind:string,name:string}>,
   *          onSeek?:(frame:number)=>void}} options segment and band ends are exclusive frame indices.
   */
  constructor(options) {
    this.options = options;
    this.frame = 0;
    this.canvas = el("canvas", {"aria-label": "subtask timeline"});
    this.margin = {left: 4, right: 4};
    this.root = el("div", {class: "timeline"}, this.canvas);
    if (options.onSeek) seekOnPointer(this.canvas, 4, 4, options.frames, options.onSeek);
  }

  draw() {
    const bands = this.options.bands || [];
    const {ctx, width, height} = setupCanvas(this.canvas, bands.length ? 62 : 44);
    const n = Math.max(1, this.options.frames);
    const px = (f) => this.margin.left + f / n * (width - this.margin.left - this.margin.right);
    this.px = px;
    ctx.clearRect(0, 0, width, height);
    ctx.font = "11px system-ui, sans-serif";
    ctx.textBaseline = "middle"; ctx.textAlign = "center";
    for (const s of this.options.segments) {
      const x0 = px(s.start); const x1 = px(s.end);
      ctx.fillStyle = subtaskColour(s.name);
      ctx.fillRect(x0, 6, Math.max(1, x1 - x0 - 1), 30);
      const label = s.target !== undefined && s.target >= 0 ? `${s.name} #${s.target}` : s.name;
      if (ctx.measureText(label).width < x1 - x0 - 6) {
        ctx.fillStyle = "#111"; ctx.fillText(label, (x0 + x1) / 2, 21);
      } else if (ctx.measureText(s.name.slice(0, 4)).width < x1 - x0 - 4) {
        ctx.fillStyle = "#111"; ctx.fillText(s.name.slice(0, 4), (x0 + x1) / 2, 21);
      }
    }
    for (const b of bands) {
      const x0 = px(b.start); const x1 = px(b.end);
      ctx.fillStyle = b.kind === "recovery" ? "#2ca02c" : "#d62728";
      ctx.fillRect(x0, 40, Math.max(2, x1 - x0), 16);
      // the name inside the band where it fits, else just after it
      const inside = ctx.measureText(b.name).width < x1 - x0 - 6;
      ctx.textAlign = "left";
      ctx.fillStyle = inside ? "#fff" : "#111";
      ctx.fillText(b.name, inside ? x0 + 3 : x1 + 3, 48);
    }
    this.base = ctx.getImageData(0, 0, this.canvas.width, this.canvas.height);
    this.ctx = ctx;
    this.height = height;
    this.setCursor(this.frame);
  }

  setCursor(frame) {
    this.frame = frame;
    if (!this.base) return;
    this.ctx.putImageData(this.base, 0, 0);
    const x = this.px(frame + 0.5);
    this.ctx.fillStyle = "#d33";
    this.ctx.fillRect(x - 1, 0, 2, this.height);
  }
}
