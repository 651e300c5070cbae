// Drawing one state onto the canvas: regions and materials, then for every
// contact the touch point, the virtual string and the pointer. Pure functions
// of (canvas, scene, frames): the renderer redraws everything each time.

export const COLORS = {
  background: "#fafafa",
  pointer: "#000000",       // the paper's pointer is black
  string: "#e8710a",        // the virtual string, pointer -> touch
  pen: "#7b1fa2",           // where the pen really is
  halo: "rgba(255,255,255,0.85)",
  label: "#3c4043",
  phase: { stick: "#d93025", slip: "#188038", hover: "#1a73e8", up: "#9aa0a6" },
};

// Sizes in CSS pixels: what a person sees, whatever the display's pixel size
// and however much the canvas is scaled down to fit the window.
export const POINTER_RADIUS = 9;
export const PHASE_RING = 17;      // outer radius of the stick/slip ring
export const STRING_WIDTH = 6;
export const PEN_RADIUS = 22;    // larger than the phase ring: seen around it when they meet
export const LABEL_PX = 15;

// Canvas pixels per CSS pixel: the canvas keeps the display's size as its
// backing store and CSS scales it to fit, so sizes are multiplied by this.
export function cssScale(canvas) {
  const shown = canvas.clientWidth || canvas.width;
  return Math.max(1, canvas.width / Math.max(1, shown));
}

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

function regionAnchor(r, k) {
  if (r.shape === "rect") return [r.rect[0] + 8 * k, r.rect[1] + 22 * k];
  if (r.shape === "circle") return [r.center[0] - r.radius * 0.6, r.center[1]];
  const xs = r.points.map((p) => p[0]);
  const ys = r.points.map((p) => p[1]);
  return [Math.min(...xs) + 8 * k, (Math.min(...ys) + Math.max(...ys)) / 2];
}

export function drawScene(ctx, scene, k = 1) {
  if (!scene) return;
  const materials = scene.materials || {};
  ctx.save();
  ctx.font = `${Math.round(LABEL_PX * k)}px system-ui, sans-serif`;
  for (const r of scene.regions || []) {
    if (!regionPath(ctx, r)) continue;
    const mat = materials[r.material];
    if (mat) {
      ctx.globalAlpha = 0.22;
      ctx.fillStyle = materialColor(mat);
      ctx.fill();
      ctx.globalAlpha = 0.7;
      ctx.strokeStyle = materialColor(mat);
      ctx.lineWidth = 2 * k;
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
    const [lx, ly] = regionAnchor(r, k);
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

function label(ctx, text, x, y, color, k, bold = false) {
  ctx.font = `${bold ? "bold " : ""}${Math.round(LABEL_PX * k)}px system-ui, sans-serif`;
  ctx.lineWidth = 4 * k;
  ctx.strokeStyle = COLORS.halo;
  ctx.lineJoin = "round";
  ctx.strokeText(text, x, y);
  ctx.fillStyle = color;
  ctx.fillText(text, x, y);
}

// The pen: a ring with tick marks outside it. Drawn first and larger than the
// pointer's phase ring, so where the two coincide it shows as an outer ring,
// and the pointer's black centre is never covered.
function drawPen(ctx, x, y, k) {
  const r = PEN_RADIUS * k;
  ctx.lineWidth = 5 * k;
  ctx.strokeStyle = COLORS.halo;
  ctx.beginPath();
  ctx.arc(x, y, r, 0, 2 * Math.PI);
  ctx.stroke();
  ctx.lineWidth = 2.5 * k;
  ctx.strokeStyle = COLORS.pen;
  ctx.beginPath();
  ctx.arc(x, y, r, 0, 2 * Math.PI);
  ctx.moveTo(x - r * 1.4, y);
  ctx.lineTo(x - r, y);
  ctx.moveTo(x + r, y);
  ctx.lineTo(x + r * 1.4, y);
  ctx.moveTo(x, y - r * 1.4);
  ctx.lineTo(x, y - r);
  ctx.moveTo(x, y + r);
  ctx.lineTo(x, y + r * 1.4);
  ctx.stroke();
}

export function drawContact(ctx, c, k = 1) {
  if (c.phase === "up") return; // the contact ended: nothing to show
  const [px, py] = c.pointer_px;
  const [tx, ty] = c.touch_px;
  const phaseColor = COLORS.phase[c.phase] || COLORS.label;
  ctx.save();
  drawPen(ctx, tx, ty, k);
  // The phase ring under everything else of this contact: red while the
  // pointer sticks, green while it slips, a thin blue one while hovering.
  ctx.beginPath();
  ctx.arc(px, py, (PHASE_RING - 3) * k, 0, 2 * Math.PI);
  ctx.strokeStyle = phaseColor;
  ctx.lineWidth = (c.phase === "hover" ? 2 : 6) * k;
  ctx.stroke();
  const end = stringEnd(c);
  if (end && c.string.length_px > 0) {
    ctx.strokeStyle = COLORS.string;
    ctx.lineWidth = STRING_WIDTH * k;
    ctx.lineCap = "round";
    ctx.beginPath();
    ctx.moveTo(px, py);
    ctx.lineTo(end[0], end[1]);
    ctx.stroke();
    const [dx, dy] = c.string.dir;
    label(ctx, `string ${c.string.length_px.toFixed(0)} px`,
      end[0] + (dx >= 0 ? 12 : -12) * k - (dx >= 0 ? 0 : 100 * k), end[1] + (dy >= 0 ? 26 : -14) * k,
      COLORS.string, k);
  }
  // The pointer: the virtual pen, black (as in the paper).
  ctx.fillStyle = COLORS.pointer;
  ctx.beginPath();
  ctx.arc(px, py, POINTER_RADIUS * k, 0, 2 * Math.PI);
  if (c.phase === "hover") {
    ctx.strokeStyle = COLORS.pointer;
    ctx.lineWidth = 2 * k;
    ctx.stroke();
  } else {
    ctx.fill();
  }
  if (c.phase === "stick" || c.phase === "slip") {
    label(ctx, c.phase === "stick" ? "sticks" : "slips", px + (PHASE_RING + 6) * k,
      py - (PHASE_RING - 2) * k, phaseColor, k, true);
  }
  ctx.restore();
}

export function drawAll(canvas, scene, frames) {
  const ctx = canvas.getContext("2d");
  const k = cssScale(canvas);
  ctx.fillStyle = COLORS.background;
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  try {
    drawScene(ctx, scene, k);
  } catch (err) { // a scene this page cannot draw must not hide the pointer
    console.warn("cannot draw the scene", err);
    ctx.restore();
  }
  for (const frame of frames) {
    for (const c of frame.contacts || []) drawContact(ctx, c, k);
  }
}
