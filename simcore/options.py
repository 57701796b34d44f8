"""Job options: one validated model shared by the API, the CLI and the pipeline (no torch import here)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from simcore.skinning.postprocess import SMOOTH_ITERATIONS

Axis = Literal["x", "y", "z", "-x", "-y", "-z"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class MotionOptions(_Strict):
    """Motion clip selection and retargeting."""

    clip: str | int | None = Field(None, description="clip name or index in the motion file (or in the mesh upload)")
    joint_map: dict[str, str] = Field(default_factory=dict, description="source joint name → target joint name overrides")
    in_place: bool = Field(False, description="remove root horizontal translation")
    fps: float | None = Field(None, gt=0, le=240, description="resample to this frame rate (default: the clip's), "
                              "rounded to a whole number: USD and FBX count whole frames per second")
    start: float | None = Field(None, ge=0, description="clip start time, seconds")
    end: float | None = Field(None, gt=0, description="clip end time, seconds")
    loop: bool = False
    unit_scale: float | None = Field(None, gt=0, description="override the guessed BVH unit → metres scale")
    relax_weights: bool = Field(True, description="move the skin weights around edges the clip crushes or stretches "
                                "past 2 % of their length, as little as the clip needs (report.json motion.relaxation); "
                                "false keeps the skin stage's weights")


class RefineOptions(_Strict):
    """PhysRig MLS-MPM refinement of the animated result."""

    enabled: bool = False
    preset: Literal["flesh", "muscle", "fat", "rubber", "stiff"] = "flesh"
    drivers: Literal["joints", "bones"] = "bones"
    grid: int = Field(64, ge=16, le=128)
    substeps: int | None = Field(None, ge=1, le=400, description="at least this many substeps per 25 fps frame "
                                 "(default: as few as the CFL bounds of the material and the drivers allow)")
    rate: float = Field(30.0, ge=10, le=60, description="simulation frame rate; output frames at the clip's rate "
                        "are interpolated between simulated ones")
    max_offset: float = Field(0.01, ge=0.0, le=0.25, description="farthest a particle may drift from its skinned "
                              "position, as a fraction of the character's height")
    prototypes: int = Field(25, ge=1, le=200)
    max_particles: int | None = Field(None, ge=1000, le=500_000)
    bone_stiffness: dict[str, float] = Field(default_factory=dict, description="joint name → Young's modulus multiplier")
    preroll_frames: int = Field(8, ge=0, le=100, description="frames easing from the bind pose into frame 0 before output")


class FbxOptions(_Strict):
    """Unit and axes of rigged.fbx / animated.fbx (simcore/io/fbx_export.py); every root node in the file is identity."""

    preset: Literal["unity", "unreal"] | None = Field(
        None, description="unity: metres, Y up (imports at scale 1, no turn); unreal: centimetres, Z up")
    units: Literal["m", "cm"] | None = Field(
        None, description="the file's unit (UnitScaleFactor 100 or 1); default: the preset's, else cm")
    up_axis: Literal["y", "z"] | None = Field(
        None, description="y: Y up, the character facing +Z (glTF's axes); z: Z up, facing -Y; default: the "
                          "preset's, else y")


class JobOptions(_Strict):
    """Everything a job can be asked to do; every field has a working default."""

    skeleton: Literal["auto", "geometric", "humanoid", "learned", "keep", "from_motion"] = Field(
        "auto", description="from_motion: recover skeleton, weights and animation from a mesh-sequence upload "
                            "(what auto does for a sequence); sequence_bones sets its bone count",
    )
    max_joints: int = Field(64, ge=2, le=256, description="the most joints a predicted skeleton may have")
    root_joint: Literal["origin", "none"] = Field(
        "origin", description="origin: a predicted skeleton hangs from a root joint at the file's origin (the "
                              "character's pivot, where game rigs carry root motion; it takes no weight), when the "
                              "origin lies near the model; none: the body's own centre joint is the root")
    sequence_bones: int | None = Field(
        None, ge=2, le=256, description="mesh sequences: the bone count to fit instead of a chosen one (at most "
                                        "max_joints), and the most joints the rig gets: bones that move alike merge, "
                                        "joints for parts the motion never bends fill up to it (report.json motion_rig "
                                        "counts both); default: the count is chosen, up to max_joints")
    up_axis: Axis | None = Field(None, description="override the input's up axis (glTF input is +Y up)")
    forward_axis: Axis | None = Field(None, description="override the facing direction used by the humanoid fit")
    units: Literal["auto", "m", "cm", "mm", "in"] = "auto"
    skinning: Literal["auto", "learned", "geodesic", "heat"] = "auto"
    max_influences: Literal[4, 8] = 4
    smooth_iterations: int = Field(SMOOTH_ITERATIONS, ge=0, le=50,
                                   description="passes of surface smoothing of the weights, which then no edge may "
                                               "carry more steeply than a bend allows; 0 keeps the method's weights")
    exclude_joints: list[Annotated[str, Field(min_length=1, max_length=200)]] = Field(
        default_factory=list, max_length=256,
        description="glob patterns (case-insensitive) of joints that get no skinning weight, e.g. a kept rig's "
                    "IK targets and controls ['*IK*', '*pole*']; they stay in the exported skeleton",
    )
    motion: MotionOptions = Field(default_factory=MotionOptions)
    refine: RefineOptions = Field(default_factory=RefineOptions)
    naming: Literal["mixamo", "unreal", "unity", "generic"] | None = Field(
        None, description="joint names of the exported rig: humanoids by bone-map table (Mixamo, Unreal mannequin, "
                          "Unity Humanoid, generic), other skeletons descriptive (spine_01, tail_03, leg_front_L_02); "
                          "default: mixamo for predicted skeletons, the upload's own names for skeleton 'keep'",
    )
    fbx: bool | FbxOptions = Field(
        False, description="also write rigged.fbx (and animated.fbx) with Blender's FBX exporter: true (centimetres, "
                           "Y up) or the unit and axes, e.g. {\"preset\": \"unity\"}; when the worker has no bpy the job "
                           "succeeds without them and says so")
    quality_gate: Literal["fail", "warn"] = Field(
        "fail", description="a result past a hard quality threshold fails the job with code quality_gate ('fail') "
                            "or succeeds with the warning flagged ('warn')",
    )
    stages: list[Literal["skeleton", "skin", "motion", "refine", "export"]] | None = Field(
        None, description="run only these stages after ingest (default: all; [] = ingest only)"
    )

    @field_validator("sequence_bones")
    @classmethod
    def _bones_within_cap(cls, bones: int | None, info: ValidationInfo) -> int | None:
        cap = info.data.get("max_joints")
        if bones is not None and cap is not None and bones > cap:
            raise ValueError(f"sequence_bones ({bones}) is more than max_joints ({cap}); raise max_joints too")
        return bones
