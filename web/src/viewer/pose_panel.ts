// The pose test: sliders turn the selected bone about its own X, Y and Z axes, so its weights can be checked on the
// deforming mesh before downloading; each bone keeps its own angles until "Reset pose".
import { h } from "../ui/dom";
import type { SceneView } from "./scene_view";

type Angles = [number, number, number];

export interface PosePanel {
  el: HTMLElement;
  /** Show the sliders of `bone` (null: none selected, sliders off). */
  select: (bone: string | null) => void;
  reset: () => void;
}

export function posePanel(view: SceneView, beforePose: () => void): PosePanel {
  const angles = new Map<string, Angles>();
  let bone: string | null = null;
  const sliders = (["x", "y", "z"] as const).map((axis, i) => {
    const out = h("output", { id: `viewer-pose-${axis}-value` }, "0°");
    const input = h("input", { type: "range", id: `viewer-pose-${axis}`, min: "-90", max: "90", step: "1", value: "0", disabled: true,
      "aria-label": `turn the selected bone about its ${axis.toUpperCase()} axis, degrees`,
      oninput: () => {
        if (!bone) return;
        beforePose();
        const a: Angles = [...(angles.get(bone) ?? [0, 0, 0])] as Angles;
        a[i] = Number(input.value);
        angles.set(bone, a);
        out.textContent = `${a[i]}°`;
        view.poseBone(bone, a);
      } }) as HTMLInputElement;
    return { input, out, row: h("label", { class: "row" }, `${axis.toUpperCase()} `, input, out) };
  });
  const resetButton = h("button", { type: "button", id: "viewer-pose-reset", onclick: () => reset() }, "Reset pose");
  const note = h("p", { class: "muted", id: "viewer-pose-note" }, "pick a bone to turn it");

  function select(name: string | null): void {
    bone = name;
    const a = (name && angles.get(name)) || [0, 0, 0];
    sliders.forEach((s, i) => { s.input.disabled = !name; s.input.value = String(a[i]); s.out.textContent = `${a[i]}°`; });
    note.textContent = name ? `turning ${name}` : "pick a bone to turn it";
  }

  function reset(): void {
    angles.clear();
    view.resetPose();
    select(bone);
  }

  const el = h("fieldset", { id: "viewer-pose" }, h("legend", {}, "Pose test"), note, ...sliders.map((s) => s.row), resetButton);
  return { el, select, reset };
}
