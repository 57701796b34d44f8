// Volume change per frame, LBS vs physics-refined (report.refine.volume_ratio_*), as a small SVG with a time cursor.
import { svg } from "../ui/dom";

export type VolumePlot = { el: SVGSVGElement; setCursor: (fraction: number) => void };

const W = 520, H = 170, PAD = { l: 46, r: 10, t: 12, b: 26 };

/** `lbs`, `refined`: (T,) volume / rest volume. Plots the change in percent against frame index. */
export function volumePlot(lbs: number[], refined: number[]): VolumePlot {
  const frames = Math.max(lbs.length, refined.length);
  const all = [...lbs, ...refined].map((v) => (v - 1) * 100);
  let lo = Math.min(0, ...all), hi = Math.max(0, ...all);
  if (hi - lo < 0.5) { lo -= 0.25; hi += 0.25; }
  const x = (i: number) => PAD.l + ((W - PAD.l - PAD.r) * i) / Math.max(frames - 1, 1);
  const y = (pct: number) => PAD.t + ((H - PAD.t - PAD.b) * (hi - pct)) / (hi - lo);
  const line = (vals: number[], color: string, name: string) => svg("polyline", { fill: "none", stroke: color, "stroke-width": 2, "data-series": name,
    points: vals.map((v, i) => `${x(i).toFixed(1)},${y((v - 1) * 100).toFixed(1)}`).join(" ") });
  const cursor = svg("line", { x1: PAD.l, x2: PAD.l, y1: PAD.t, y2: H - PAD.b, stroke: "#888", "stroke-dasharray": "3 3" });
  const ticks = [...new Set([lo, 0, hi])].map((v) => svg("text", { x: PAD.l - 6, y: y(v) + 4, "text-anchor": "end" }, `${v.toFixed(1)}%`));
  const el = svg("svg", { class: "plot", id: "volume-plot", viewBox: `0 0 ${W} ${H}`, style: `width:100%;max-width:${W * 1.4}px;height:auto`, role: "img",
    "aria-label": "volume change per frame, LBS and physics-refined" },
  svg("title", {}, "Volume change relative to the rest pose, per frame"),
  svg("line", { x1: PAD.l, x2: W - PAD.r, y1: y(0), y2: y(0), stroke: "#ccc" }),
  svg("line", { x1: PAD.l, x2: PAD.l, y1: PAD.t, y2: H - PAD.b, stroke: "#ccc" }),
  ...ticks,
  svg("text", { x: W / 2, y: H - 6, "text-anchor": "middle" }, `frame (0–${frames - 1})`),
  line(lbs, "#d0572a", "lbs"), line(refined, "#2f5fd0", "refined"), cursor,
  svg("text", { x: W - PAD.r - 150, y: PAD.t + 10, style: "fill:#d0572a" }, "— LBS"),
  svg("text", { x: W - PAD.r - 80, y: PAD.t + 10, style: "fill:#2f5fd0" }, "— physics"));
  return { el, setCursor: (f: number) => { const cx = x(f * (frames - 1)); cursor.setAttribute("x1", String(cx)); cursor.setAttribute("x2", String(cx)); } };
}
