// Small DOM and fetch helpers shared by the views.

/** Create an element: el("div", {class: "x", onclick: fn}, child, "text", ...). */
export function el(tag, attrs = {}, ...children) {
  const node = tag.startsWith("svg:")
    ? document.createElementNS("http://www.w3.org/2000/svg", tag.slice(4))
    : document.createElement(tag);
  for (const [key, value] of Object.entries(attrs || {})) {
    if (value === undefined || value === null || value === false) continue;
    if (key.startsWith("on") && typeof value === "function") node.addEventListener(key.slice(2), value);
    else if (key === "text") node.textContent = value;
    else node.setAttribute(key, value === true ? "" : String(value));
  }
  for (const child of children.flat()) {
    if (child === undefined || child === null || child === false) continue;
    node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return node;
}

/** Replace a node's children, skipping null / undefined / false. */
export function fill(node, ...children) {
  node.replaceChildren(...children.flat().filter((c) => c !== null && c !== undefined && c !== false));
  return node;
}

/** Error carrying the HTTP status and the server's one-line message. */
export class HttpError extends Error {
  constructor(status, message) {
    super(message);
    this.status = status;
  }
}

async function check(response) {
  if (response.ok) return response;
  let message = `${response.status} ${response.statusText}`;
  try {
    const body = await response.json();
    if (body && body.error) message = body.error;
  } catch (_) { /* not JSON */ }
  throw new HttpError(response.status, message);
}

/** GET a JSON document; throws HttpError with the server's message. */
export async function getJSON(url) {
  return (await check(await fetch(url, {cache: "no-store"}))).json();
}

/** GET raw little-endian pixels with X-Width / X-Height / X-Dtype headers. */
export async function getPixels(url) {
  const response = await check(await fetch(url, {cache: "no-store"}));
  const width = Number(response.headers.get("X-Width"));
  const height = Number(response.headers.get("X-Height"));
  const dtype = response.headers.get("X-Dtype");
  const buffer = await response.arrayBuffer();
  const Kind = {uint8: Uint8Array, uint16: Uint16Array, int32: Int32Array}[dtype] || Uint8Array;
  return {width, height, data: new Kind(buffer)};
}

/** Format a number with a fixed count of decimals, or "–" when missing. */
export function num(value, digits = 3) {
  return typeof value === "number" && Number.isFinite(value) ? value.toFixed(digits) : "–";
}

/** "rgb(r,g,b)" of a [r, g, b] triple. */
export function rgb(c) {
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

/** Parse "#/a/b?x=1" into {parts: ["a", "b"], query: {x: "1"}}. */
export function parseHash(hash) {
  const text = (hash || "").replace(/^#\/?/, "");
  const [path, search = ""] = text.split("?");
  const parts = path.split("/").filter(Boolean).map(decodeURIComponent);
  const query = Object.fromEntries(new URLSearchParams(search));
  return {parts, query};
}

/** A swatch span in a colour. */
export function swatch(colour) {
  const node = el("span", {class: "swatch"});
  node.style.background = colour;
  return node;
}

/** Names of colours as CSS colours, for legends of object attributes. */
export const COLOUR_CSS = {
  black: "#222", blue: "#2f6fd6", brown: "#8a5a2b", cyan: "#20b8c8", green: "#2e9e44", metallic: "#a8adb4",
  purple: "#7d3fc0", red: "#d33", transparent: "#e8f4fa", white: "#f4f4f4", yellow: "#f2cf1d",
};
