// Episode player: play/pause, scrubber, frame stepping, camera images (RGB / depth / segmentation,
// fetched one frame at a time), a top view of the table drawn from the recorded poses, the subtask
// timeline, and plots of joint positions, gripper and the 7-D steering vector.
import {COLOUR_CSS, el, fill, getJSON, num} from "./util.js";
import {LinePlot, subtaskColour, Timeline} from "./plot.js";

const SPEEDS = [0.25, 0.5, 1, 2, 4];
const STEERING_NAMES = ["vx", "vy", "vz", "wx", "wy", "wz", "grip"];

/**
 * Build the player for episode `k` inside `root`; returns a cleanup function (stops playback and
 * removes global listeners).
 */
export async function openPlayer(root, k) {
  const ep = await getJSON(`/api/episodes/${encodeURIComponent(k)}`);
  const s = ep.series;
  const frames = ep.num_frames;
  let scene = null;
  try { scene = (await getJSON(`/api/scenes/${ep.scene_index}`)).scene; } catch (_) { /* scene not written */ }
  const state = {frame: 0, playing: false, speed: 1, camera: Object.keys(ep.cameras)[0] || "", modality: "rgb",
    busy: false, timer: null};

  // ---- views
  const img = el("img", {id: "episode-frame", alt: "episode frame"});
  const camBlock = el("div", {class: "cam"});
  const cameraNames = Object.keys(ep.cameras);
  if (cameraNames.length) camBlock.append(img);
  else camBlock.append(el("div", {class: "placeholder", id: "no-images"},
    "this episode stores no images; the top view is drawn from its recorded poses"));
  img.addEventListener("load", () => { state.busy = false; });
  img.addEventListener("error", () => { state.busy = false; });
  const top = el("canvas", {id: "topview", width: 340, height: 300, "aria-label": "top view of the table"});
  const views = el("div", {class: "views"}, camBlock,
    el("div", {class: "topview"}, el("div", {class: "muted"}, "top view (operator at the bottom)"), top));

  // ---- controls
  const scrub = el("input", {type: "range", min: 0, max: Math.max(0, frames - 1), value: 0, step: 1, id: "scrubber",
    "aria-label": "frame"});
  const label = el("span", {class: "frame-label", id: "frame-label"});
  const playButton = el("button", {type: "button", id: "play", title: "play / pause (space)"}, "▶ play");
  const button = (text, title, action, id) => el("button", {type: "button", title, id, onclick: action}, text);
  const speed = el("select", {id: "speed", "aria-label": "speed", onchange: (e) => { state.speed = Number(e.target.value); restart(); }},
    SPEEDS.map((v) => el("option", {value: v}, `${v}×`)));
  speed.value = "1";
  const cameraSelect = el("select", {id: "camera", "aria-label": "camera", onchange: (e) => { state.camera = e.target.value; show(); }},
    cameraNames.map((c) => el("option", {value: c}, c)));
  const modalityBox = el("div", {class: "toggle", role: "group"});
  for (const m of ["rgb", "depth", "segmentation"]) {
    const available = cameraNames.length && (ep.cameras[state.camera] || []).includes(m);
    const b = el("button", {type: "button", "data-modality": m, disabled: !available, title: available ? m : "not stored"},
      m === "rgb" ? "RGB" : m[0].toUpperCase() + m.slice(1));
    b.classList.toggle("active", m === "rgb");
    b.addEventListener("click", () => {
      state.modality = m;
      for (const x of modalityBox.children) x.classList.toggle("active", x === b);
      show();
    });
    modalityBox.append(b);
  }
  const controls = el("div", {class: "player-controls"},
    button("|◀◀", "first frame (Home)", () => seek(0), "first"),
    button("◀|", "previous frame (←)", () => seek(state.frame - 1), "step-back"),
    playButton,
    button("|▶", "next frame (→)", () => seek(state.frame + 1), "step"),
    button("▶▶|", "last frame (End)", () => seek(frames - 1), "last"),
    speed, scrub, label);
  const info = el("div", {class: "panel", id: "frame-info"});

  // ---- timeline and plots
  const onSeek = (f) => { pause(); seek(f); };
  const timeline = new Timeline({segments: ep.segments, bands: ep.bands, frames, onSeek});
  const time = s.time;
  const column = (rows, j) => rows.map((r) => (r ? r[j] : NaN));
  const jointNames = s.joint_names || ["j1", "j2", "j3", "j4", "j5", "j6"];
  const plots = [
    new LinePlot({title: "joint positions", unit: "rad", time, onSeek,
      series: jointNames.map((n, j) => ({name: n.replace(/_joint$/, ""), values: column(s.joint_pos, j)}))}),
    new LinePlot({title: "gripper", unit: "opening mm / command", time, onSeek, height: 110,
      series: [{name: "opening [mm]", values: s.gripper_opening.map((v) => v * 1000), colour: "#2ca02c"},
        {name: "command ×40 (+1 open, −1 close)", values: s.gripper_command.map((v) => v * 40), colour: "#9467bd"}]}),
    new LinePlot({title: "steering vector", unit: "−1…1", time, onSeek, range: [-1.05, 1.05],
      series: STEERING_NAMES.map((n, j) => ({name: n, values: column(s.steering, j)}))}),
  ];
  const verdict = ep.success
    ? el("span", {class: "verdict ok", id: "verdict"}, "✓ success")
    : el("span", {class: "verdict bad", id: "verdict"}, `✗ failure${ep.failure_reason ? `: ${ep.failure_reason}` : ""}`);
  const legend = el("div", {class: "legend"}, [...new Set(ep.segments.map((g) => g.name))].map((n) => {
    const sw = el("span", {class: "swatch"});
    sw.style.background = subtaskColour(n);
    return el("span", {}, sw, n);
  }));
  fill(root,
    el("h1", {}, `Episode ${k} — ${ep.family}`),
    el("div", {class: "toolbar"}, verdict,
      el("a", {href: `#/instruction/${ep.instruction_index}`}, `“${ep.instruction || `instruction ${ep.instruction_index}`}”`),
      el("a", {href: `#/scene/${ep.scene_index}`}, `scene ${ep.scene_index}`),
      el("span", {class: "muted"}, `${frames} frames at ${num(ep.control_hz, 0)} Hz`),
      ep.previous ? el("a", {href: `#/episode/${ep.previous}`}, "‹ previous episode") : null,
      ep.next ? el("a", {href: `#/episode/${ep.next}`}, "next episode ›") : null),
    el("div", {class: "toolbar"}, cameraNames.length > 1 ? cameraSelect : null, cameraNames.length ? modalityBox : null,
      ep.rendered_on_demand ? el("span", {class: "muted", id: "rendered-note"},
        "this episode stores no images: frames are rendered on demand from its recorded physics states") : null),
    views, controls, info, el("h3", {}, "Subtasks"), timeline.root, legend, ...plots.map((p) => p.root),
    el("h3", {}, "Checker and generation report"), el("pre", {class: "json", id: "episode-info"}, JSON.stringify(ep.info, null, 1)));

  // ---- behaviour
  function frameUrl(f) {
    const q = new URLSearchParams({camera: state.camera, modality: state.modality,
      format: state.modality === "rgb" ? "jpeg" : "png", v: ep.version || ""});
    return `/api/episodes/${k}/frame/${f}?${q}`;
  }
  const prefetched = new Map();
  function prefetch(f) {
    // warm the browser cache with the next frames so that playback does not wait on each request
    for (let g = f + 1; g <= Math.min(frames - 1, f + 4); g++) {
      const url = frameUrl(g);
      if (prefetched.has(url)) continue;
      const image = new Image();
      image.src = url;
      prefetched.set(url, image);
      if (prefetched.size > 64) prefetched.delete(prefetched.keys().next().value);
    }
  }
  function show() {
    const f = state.frame;
    const url = frameUrl(f);
    if (cameraNames.length && img.getAttribute("src") !== url) {
      state.busy = true;
      img.src = url;
    }
    if (cameraNames.length && state.playing) prefetch(f);
    scrub.value = String(f);
    const sub = ep.subtasks[s.subtask_index[f]] ?? "?";
    label.textContent = `frame ${f + 1} / ${frames} · t = ${num(time[f], 2)} s`;
    const objName = (i) => (i >= 0 && scene && scene.objects[i] ? `#${i} ${scene.objects[i].name}` : i >= 0 ? `#${i}` : "none");
    info.replaceChildren(el("span", {id: "subtask-now"}, el("strong", {}, "subtask "), sub),
      el("span", {}, " · target ", objName(s.target_object[f])),
      el("span", {}, " · grasped ", objName(s.grasped_object[f])),
      el("span", {}, ` · gripper ${num(s.gripper_opening[f] * 1000, 1)} mm`),
      ...(s.safety_event[f] ? [el("span", {class: "error"}, ` · safety event ${s.safety_event[f]}`)] : []));
    timeline.setCursor(f);
    for (const p of plots) p.setCursor(f);
    drawTop(top, ep, scene, f);
  }
  function seek(f) {
    state.frame = Math.max(0, Math.min(frames - 1, f));
    show();
  }
  function tick() {
    if (state.busy) return;  // wait for the current image: playback slows down instead of queueing
    if (state.frame >= frames - 1) { pause(); return; }
    seek(state.frame + 1);
  }
  function play() {
    if (state.frame >= frames - 1) seek(0);
    state.playing = true;
    playButton.textContent = "⏸ pause";
    restart();
  }
  function pause() {
    state.playing = false;
    playButton.textContent = "▶ play";
    clearInterval(state.timer);
    state.timer = null;
  }
  function restart() {
    clearInterval(state.timer);
    if (state.playing) state.timer = setInterval(tick, 1000 / ((ep.control_hz || 20) * state.speed));
  }
  playButton.addEventListener("click", () => (state.playing ? pause() : play()));
  scrub.addEventListener("input", () => { pause(); seek(Number(scrub.value)); });
  const keys = (e) => {
    if (e.target.tagName === "INPUT" || e.target.tagName === "SELECT") return;
    if (e.key === " ") { e.preventDefault(); state.playing ? pause() : play(); }
    else if (e.key === "ArrowRight") { pause(); seek(state.frame + 1); }
    else if (e.key === "ArrowLeft") { pause(); seek(state.frame - 1); }
    else if (e.key === "Home") { pause(); seek(0); }
    else if (e.key === "End") { pause(); seek(frames - 1); }
  };
  const resize = () => { timeline.draw(); for (const p of plots) p.draw(); };
  document.addEventListener("keydown", keys);
  window.addEventListener("resize", resize);
  resize();
  show();
  return () => {
    pause();
    document.removeEventListener("keydown", keys);
    window.removeEventListener("resize", resize);
  };
}

/** Top view of the table (operator at the bottom, robot at the top) from recorded poses at frame f. */
function drawTop(canvas, ep, scene, f) {
  const ctx = canvas.getContext("2d");
  const W = canvas.width; const H = canvas.height;
  const lay = ep.layout;
  const [tx, ty] = lay.table_size;
  const scale = Math.min((W - 20) / ty, (H - 20) / tx);
  // world (x, y) → canvas: left (−y) to the left, front (+x) down
  const cx = (y) => W / 2 + y * scale;
  const cy = (x) => H / 2 + x * scale;
  ctx.clearRect(0, 0, W, H);
  ctx.fillStyle = "#d9c7ad";
  ctx.fillRect(cx(-ty / 2), cy(-tx / 2), ty * scale, tx * scale);
  const [x0, y0] = lay.workspace_min; const [x1, y1] = lay.workspace_max;
  ctx.strokeStyle = "#a08866"; ctx.setLineDash([4, 3]);
  ctx.strokeRect(cx(y0), cy(x0), (y1 - y0) * scale, (x1 - x0) * scale);
  const [wcx, wcy] = lay.workspace_center; const h = lay.band / 2;
  ctx.fillStyle = "rgba(255,255,255,0.35)";
  ctx.fillRect(cx(wcy - h), cy(x0), lay.band * scale, (x1 - x0) * scale);
  ctx.fillRect(cx(y0), cy(wcx - h), (y1 - y0) * scale, lay.band * scale);
  ctx.setLineDash([]);
  ctx.fillStyle = "#7a6a55"; ctx.font = "11px system-ui, sans-serif"; ctx.textAlign = "center";
  ctx.fillText("left", cx(y0) + 18, cy(wcx) + 4); ctx.fillText("right", cx(y1) - 20, cy(wcx) + 4);
  ctx.fillText("back", cx(wcy), cy(x0) + 12); ctx.fillText("front", cx(wcy), cy(x1) - 4);
  // robot base
  ctx.fillStyle = "#666";
  ctx.beginPath(); ctx.arc(cx(lay.robot_base[1]), cy(lay.robot_base[0]), 0.07 * scale, 0, 2 * Math.PI); ctx.fill();
  const s = ep.series;
  const objects = (scene && scene.objects) || [];
  const poses = s.object_pos[f] || [];
  poses.forEach((p, i) => {
    const o = objects[i] || {};
    const half = o.footprint_half_extents || [0.04, 0.04];
    const r = Math.max(0.015, Math.min(half[0], half[1], 0.12)) * scale;
    ctx.fillStyle = COLOUR_CSS[o.colour || o.color] || "#bbb";
    ctx.strokeStyle = s.grasped_object[f] === i ? "#d33" : s.target_object[f] === i ? "#ff7800" : "#333";
    ctx.lineWidth = s.grasped_object[f] === i || s.target_object[f] === i ? 3 : 1;
    ctx.beginPath(); ctx.arc(cx(p[1]), cy(p[0]), r, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    ctx.fillStyle = "#111"; ctx.fillText(String(i), cx(p[1]), cy(p[0]) + 4);
  });
  // TCP trail and position
  ctx.strokeStyle = "rgba(31,111,235,0.6)"; ctx.lineWidth = 1.5; ctx.beginPath();
  for (let t = 0; t <= f; t++) {
    const q = s.tcp_pos[t];
    if (t === 0) ctx.moveTo(cx(q[1]), cy(q[0])); else ctx.lineTo(cx(q[1]), cy(q[0]));
  }
  ctx.stroke();
  const q = s.tcp_pos[f];
  ctx.strokeStyle = "#1f6feb"; ctx.lineWidth = 2.5;
  ctx.beginPath();
  ctx.moveTo(cx(q[1]) - 7, cy(q[0])); ctx.lineTo(cx(q[1]) + 7, cy(q[0]));
  ctx.moveTo(cx(q[1]), cy(q[0]) - 7); ctx.lineTo(cx(q[1]), cy(q[0]) + 7);
  ctx.stroke();
  ctx.fillStyle = "#1f6feb"; ctx.textAlign = "left";
  ctx.fillText(`TCP z ${num(q[2], 2)} m`, 6, H - 6);
}
