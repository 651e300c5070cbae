// Drawing one state onto the canvas: regions and materials, then for every
// contact the touch point, the virtual string and the pointer. Pure functions
// of (canvas, scene, frames): the renderer redraws everything each time.

export const COLORS = {
  background: "#fafafa",
  pointer: "#000000",       // the paper's pointer is black
  string: "#e8710a",        // the virtual string, pointer -> touch
  touch: "#5f6368",
  label: "#3c4043",
  phase: { stick: "#d93025", slip: "#188038", hover: "#1a73e8", up: "#9aa0a6" },
};

export const POINTER_RADIUS = 7;
export const STRING_WIDTH = 3;

// A material without a colour gets one from its stickiness: blue (slippery)
// to red (sticky), so two scenes with the same mu_s look alike.
export function materialColor(material) {
  if (material && typeof material.color === "string") return material.color;
  const mu = material && Number.isFinite(material.mu_s) ? material.mu_s : 0;
  const hue = 210 - 210 * Math.max(0, Math.min(1, mu));
  return `hsl(${hue}, 65%, 55%)`;
}

function regionPath(ctx, r) {
  ctx.beginPath();
  if (r.shape === "rect" && Array.isArray(r.rect)) {
    const [x, y, w, h] = r.rect;
    ctx.rect(x, y, w, h);
  } else if (r.shape === "circle" && Array.isArray(r.center)) {
    ctx.arc(r.center[0], r.center[1], r.radius, 0, 2 * Math.PI);
  } else if (r.shape === "polygon" && Array.isArray(r.points) && r.points.length > 2) {
    ctx.moveTo(r.points[0][0], r.points[0][1]);
    for (const [x, y] of r.points.slice(1)) ctx.lineTo(x, y);
    ctx.closePath();
  } else {
    return false;
  }
  return true;
}

function regionAnchor(r) {
  if (r.shape === "rect") return [r.rect[0] + 8, r.rect[1] + 18];
  if (r.shape === "circle") return [r.center[0] - r.radius * 0.6, r.center[1]];
  const xs = r.points.map((p) => p[0]);
  const ys = r.points.map((p) => p[1]);
  return [Math.min(...xs) + 8, (Math.min(...ys) + Math.max(...ys)) / 2];
}

export function drawScene(ctx, scene) {
  if (!scene) return;
  const materials = scene.materials || {};
  ctx.save();
  ctx.font = "14px system-ui, sans-serif";
  for (const r of scene.regions || []) {
    if (!regionPath(ctx, r)) continue;
    const mat = materials[r.material];
    if (mat) {
      ctx.globalAlpha = 0.22;
      ctx.fillStyle = materialColor(mat);
      ctx.fill();
      ctx.globalAlpha = 0.7;
      ctx.strokeStyle = materialColor(mat);
      ctx.lineWidth = 2;
      ctx.stroke();
    } else { // pass-through: a hole, outlined only
      ctx.globalAlpha = 0.5;
      ctx.setLineDash([6, 6]);
      ctx.strokeStyle = COLORS.label;
      ctx.stroke();
      ctx.setLineDash([]);
    }
    ctx.globalAlpha = 1;
    ctx.fillStyle = COLORS.label;
    const [lx, ly] = regionAnchor(r);
    const mu = mat ? `  μs ${mat.mu_s}  μk ${mat.mu_k}` : "";
    ctx.fillText(`${r.name || ""} · ${r.material}${mu}`, lx, ly);
  }
  ctx.restore();
}

export function stringEnd(c) {
  if (!c.string) return null;
  const [px, py] = c.pointer_px;
  const [dx, dy] = c.string.dir;
  return [px + dx * c.string.length_px, py + dy * c.string.length_px];
}

export function drawContact(ctx, c) {
  if (c.phase === "up") return; // the contact ended: nothing to show
  const [px, py] = c.pointer_px;
  const [tx, ty] = c.touch_px;
  ctx.save();
  // Touch point: where the pen really is (a small ring, drawn first, underneath).
  ctx.strokeStyle = COLORS.touch;
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  ctx.arc(tx, ty, 4, 0, 2 * Math.PI);
  ctx.stroke();
  const end = stringEnd(c);
  if (end && c.string.length_px > 0) {
    ctx.strokeStyle = COLORS.string;
    ctx.lineWidth = STRING_WIDTH;
    ctx.lineCap = "round";
    ctx.beginPath();
    ctx.moveTo(px, py);
    ctx.lineTo(end[0], end[1]);
    ctx.stroke();
    ctx.fillStyle = COLORS.string;
    ctx.font = "12px system-ui, sans-serif";
    ctx.fillText(`${c.string.length_px.toFixed(0)} px`, end[0] + 8, end[1] - 8);
  }
  // Pointer: the virtual pen, black, ringed by its phase colour.
  ctx.fillStyle = COLORS.pointer;
  ctx.beginPath();
  ctx.arc(px, py, POINTER_RADIUS, 0, 2 * Math.PI);
  if (c.phase === "hover") {
    ctx.strokeStyle = COLORS.pointer;
    ctx.lineWidth = 2;
    ctx.stroke();
  } else {
    ctx.fill();
    ctx.strokeStyle = COLORS.phase[c.phase] || COLORS.label;
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.arc(px, py, POINTER_RADIUS + 3, 0, 2 * Math.PI);
    ctx.stroke();
  }
  ctx.restore();
}

export function drawAll(canvas, scene, frames) {
  const ctx = canvas.getContext("2d");
  ctx.fillStyle = COLORS.background;
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  try {
    drawScene(ctx, scene);
  } catch (err) { // a scene this page cannot draw must not hide the pointer
    console.warn("cannot draw the scene", err);
    ctx.restore();
  }
  for (const frame of frames) {
    for (const c of frame.contacts || []) drawContact(ctx, c);
  }
}
