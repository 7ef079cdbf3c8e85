// Object masks from instance-id pixels: tinted fill and a thick outline, drawn on an overlay canvas.

/**
 * Draw the masks of groups of segmentation ids on a canvas of the ids' size.
 * @param {HTMLCanvasElement} canvas overlay canvas (resized to the ids' width and height).
 * @param {{width:number,height:number,data:ArrayLike<number>}} ids instance-id pixels.
 * @param {Array<{ids:number[], colour:number[], fill?:number}>} groups colour [r,g,b] and fill alpha per group.
 * @param {number} thickness outline thickness [px].
 */
export function drawMasks(canvas, ids, groups, thickness = 2) {
  const {width, height, data} = ids;
  canvas.width = width;
  canvas.height = height;
  const ctx = canvas.getContext("2d");
  const image = ctx.createImageData(width, height);
  const out = image.data;
  const groupOf = new Map();
  groups.forEach((g, k) => g.ids.forEach((id) => groupOf.set(id, k)));
  if (groupOf.size === 0) {
    ctx.clearRect(0, 0, width, height);
    return;
  }
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      const p = y * width + x;
      const k = groupOf.get(data[p]);
      if (k === undefined) continue;
      const id = data[p];
      let edge = false;
      for (let d = 1; d <= thickness && !edge; d++) {
        edge = (x - d < 0 || data[p - d] !== id) || (x + d >= width || data[p + d] !== id)
          || (y - d < 0 || data[p - d * width] !== id) || (y + d >= height || data[p + d * width] !== id);
      }
      const c = groups[k].colour;
      const o = 4 * p;
      out[o] = c[0]; out[o + 1] = c[1]; out[o + 2] = c[2];
      out[o + 3] = edge ? 255 : Math.round(255 * (groups[k].fill ?? 0.25));
    }
  }
  ctx.putImageData(image, 0, 0);
}

/** Instance id at a mouse event's position over an element showing the ids' image. */
export function idAt(event, element, ids) {
  const rect = element.getBoundingClientRect();
  const x = Math.floor((event.clientX - rect.left) / rect.width * ids.width);
  const y = Math.floor((event.clientY - rect.top) / rect.height * ids.height);
  if (x < 0 || y < 0 || x >= ids.width || y >= ids.height) return {x, y, id: -1, p: -1};
  const p = y * ids.width + x;
  return {x, y, id: ids.data[p], p};
}
