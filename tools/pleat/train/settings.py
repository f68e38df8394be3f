"""Every training setting, declared once: its key, its default, the values it takes and what it means.

A run's config is built from these declarations alone (`resolve`): every key starts at its declared default, a
preset (configs/<name>.json) overrides some of them, and `--set KEY=JSON` overrides again. The training code then
reads the resolved config as a plain nested dict (`cfg["stage1"]["lr"]`) and never supplies a default of its own, so
a default lives in exactly one place. A key no declaration names, or a value outside its declared range, is refused
before anything runs, naming the key and what it takes.

A declared default is what a preset that leaves the key out gets; the `default` preset sets many keys to other
values (the shipped recipe), `tiny` to smaller ones (the tests). `pleat-train config --preset NAME` prints what a
run resolves to, key by key, with the meanings below; docs/settings.md carries the same table
(`pleat-train config --markdown`).

Configs stored with older runs (checkpoints, run folders) may lack keys declared since; `complete` fills them with
the declared defaults, which are the defaults their readers used, so an old run reads as it did.
"""
import difflib
import json
from dataclasses import dataclass
from pathlib import Path

from pleat import REPO_ROOT
from pleat.cli import InputError

PRESETS_DIR = REPO_ROOT / "configs"


class SettingError(InputError):
    """A preset or an override names an unknown key or gives a value outside its key's range."""


# ---- what values a key takes ---------------------------------------------------------------------------------------
def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


@dataclass(frozen=True)
class Integer:
    lo: int = None
    hi: int = None

    @property
    def text(self):
        return _range_text("integer", self.lo, self.hi)

    def check(self, v):
        if isinstance(v, bool) or not isinstance(v, int) or not _within(v, self.lo, self.hi):
            raise ValueError(self.text)
        return v


@dataclass(frozen=True)
class Number:
    lo: float = None
    hi: float = None
    above: float = None          # an open lower bound: "> above"

    @property
    def text(self):
        if self.above is not None:
            return f"number > {self.above:g}"
        return _range_text("number", self.lo, self.hi)

    def check(self, v):
        if not _is_number(v) or v != v or abs(v) == float("inf") or not _within(v, self.lo, self.hi) or (
                self.above is not None and not v > self.above):
            raise ValueError(self.text)
        return float(v)


@dataclass(frozen=True)
class Flag:
    text = "true or false"

    def check(self, v):
        if not isinstance(v, bool):
            raise ValueError(self.text)
        return v


class OneOf:
    """Exactly one of a few JSON values (true is not 1, "1" is not 1)."""

    def __init__(self, *options):
        self.options = options
        self.text = ", ".join(json.dumps(o) for o in options[:-1]) + f" or {json.dumps(options[-1])}"

    def check(self, v):
        if not any(type(v) is type(o) and v == o for o in self.options):
            raise ValueError(self.text)
        return v


@dataclass(frozen=True)
class Text:
    text: str = "a string"
    null: bool = False           # null allowed too

    def check(self, v):
        if not (isinstance(v, str) or (self.null and v is None)):
            raise ValueError(self.text)
        return v


@dataclass(frozen=True)
class TierName:
    text = "a tier name (pleat.eval.tiers: xsmall, small, medium, member, large, or <count>x<tier>)"

    def check(self, v):
        from pleat.eval.tiers import tier
        try:
            tier(v) if isinstance(v, str) else None
        except ValueError:
            v = None
        if not isinstance(v, str):
            raise ValueError(self.text)
        return v


@dataclass(frozen=True)
class ListOf:
    item: object
    length: int = None
    min_length: int = 0

    @property
    def text(self):
        if self.length:
            return "[" + ", ".join([self.item.text] * self.length) + "]"
        return ("non-empty " if self.min_length else "") + f"[{self.item.text}, ...]"

    def check(self, v):
        if not isinstance(v, list) or (self.length and len(v) != self.length) or len(v) < self.min_length:
            raise ValueError(self.text)
        try:
            return [self.item.check(x) for x in v]
        except ValueError:
            raise ValueError(self.text) from None


@dataclass(frozen=True)
class FlagOrCount:
    text = "false, true or a count >= 0"

    def check(self, v):
        if not isinstance(v, bool) and (not isinstance(v, int) or v < 0):
            raise ValueError(self.text)
        return v


def _within(v, lo, hi):
    return (lo is None or v >= lo) and (hi is None or v <= hi)


def _range_text(what, lo, hi):
    if lo is not None and hi is not None:
        return f"{what} in [{lo:g}, {hi:g}]"
    if lo is not None:
        return f"{what} >= {lo:g}"
    return f"{what} <= {hi:g}" if hi is not None else what


# ---- the declarations ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Setting:
    key: str            # "section.name" or "name" (top level)
    default: object
    values: object      # Integer, Number, ... : check(value) -> value, text
    meaning: str


# The simulator's training-clip variants (pleat.train.simdata.VARIANTS) and the MLP activations
# (pleat.train.model.ACTIVATIONS), named here so that resolving a config needs neither torch nor the simulator;
# tests/python/test_train_settings.py checks that the lists agree.
VARIANTS = ("original", "mirrored", "fast", "slow", "collar", "stop", "blend", "noise")
ACTIVATIONS = ("relu", "silu")

COUNT, POSITIVE = Integer(0), Integer(1)
PAIR = ListOf(Number(0.0), length=2)
S = Setting
SETTINGS = (
    S("preset", None, Text("a string or null", null=True),
      "the preset's name (default: the file's), recorded in the run and the asset's META"),
    S("seed", 0, COUNT, "seed of every random choice (windows, β, materials, initial weights, graphs)"),
    S("fps", 30.0, Number(above=0), "frame rate the clips are resampled to, frames/s"),
    S("garment_vertices", 1000, Integer(3), "target vertex count of a generated garment (--garment NAME)"),
    S("body", "assets/body.npz", Text("a body npz path"), "body model npz, relative to the repository"),

    S("clips.train_limit", 0, COUNT, "use the first N training clips (0: all)"),
    S("clips.validation_limit", 0, COUNT, "use the first N validation clips (0: all)"),
    S("clips.frames_limit", 0, COUNT, "use the first N frames of each clip (0: all)"),

    S("model.hidden", 32, POSITIVE, "Φ's width: encoder, message passing and decoder features"),
    S("model.mp_levels", 3, POSITIVE, "levels of Φ's graph hierarchy"),
    S("model.mp_schedule", [0, 1, 2, 1, 0], ListOf(COUNT, min_length=1), "the level of each message-passing step"),
    S("model.body_radius_m", 0.05, Number(above=0), "body-garment edges within this distance, m"),
    S("model.body_subset_m", 0.12, Number(0.0), "pose only body vertices this close to the garment, m (0: all)"),
    S("model.conv_steps", 4, POSITIVE, "down-samplings of the compressor"),
    S("model.conv_neighbours", 9, POSITIVE, "neighbours of each compressor convolution"),
    S("model.conv_channels", [16, 16, 16, 16], ListOf(POSITIVE, min_length=1), "compressor channels per step"),
    S("model.conv_bases", 16, POSITIVE, "kernel bases of each compressor convolution"),
    S("model.latent", 128, POSITIVE, "L: latent size"),
    S("model.blend", 128, POSITIVE, "D: blend shapes"),
    S("model.dec_hidden", [512, 512], ListOf(POSITIVE), "f_dec's hidden layer widths"),
    S("model.lp_hidden", [512, 512, 512], ListOf(POSITIVE), "f_LP's hidden layer widths"),
    S("model.activation", "relu", OneOf(*ACTIVATIONS), "activation of f_LP and f_dec"),
    S("model.blend_init_m", 1e-5, Number(0.0), "blend shapes' initial random scale, m"),

    S("stage1.iterations", 6000, POSITIVE, "stage-1 iterations (the schedules run over them)"),
    S("stage1.lr", 2e-4, Number(above=0), "stage-1 Adam learning rate"),
    S("stage1.blend_lr_scale", 1.0, Number(0.0), "blend shapes' learning rate as a multiple of lr"),
    S("stage1.grad_clip", 1.0, Number(above=0), "gradient norm clip"),
    S("stage1.rollout_max", 5, POSITIVE, "longest rollout, steps"),
    S("stage1.rollout_every", 0.0417, Number(above=0), "one more rollout step every this fraction of the run"),
    S("stage1.w_bending", 1.0, Number(0.0), "weight of the bending energy"),
    S("stage1.w_stretching", 1.0, Number(0.0), "weight of the stretching energy"),
    S("stage1.w_inertia", [3.0, 5.0], PAIR, "weight of the inertia term, [start, end] of the run"),
    S("stage1.w_gravity", [2.0, 3.0], PAIR, "weight of the gravity work, [start, end] of the run"),
    S("stage1.w_friction", 1.0, Number(0.0), "weight of friction (times the collision weight)"),
    S("stage1.w_collision", [5000.0, 8000000.0], PAIR, "weight of the collision term, [start, end] of its ramp"),
    S("stage1.collision_ramp", [0.4167, 0.8333], ListOf(Number(0.0, 1.0), length=2),
      "where the collision weight ramps, fractions of the run"),
    S("stage1.beta_max", 3.0, Number(0.0), "β ~ U(−beta_max, beta_max) per component"),
    S("stage1.checkpoint_every", 100, POSITIVE, "iterations between checkpoints"),
    S("stage1.validation_windows", 12, POSITIVE, "windows of the validation"),
    S("stage1.validation_every", 0, COUNT, "iterations between validations (0: at the end only)"),
    S("stage1.loss_norm", None, OneOf(None, "lbs"),
      "\"lbs\": divide each window's loss by its LBS-only loss; null: raw loss"),
    S("stage1.loss_norm_floor", 1.0, Number(above=0), "least LBS-only loss divided by, J"),
    S("stage1.exclude_clips", [], ListOf(Text()), "leave out training clips whose name contains any of these"),
    S("stage1.batched", True, Flag(), "batched windows (false: the per-window path, for comparisons)"),
    S("stage1.windows_per_iteration", 1, POSITIVE, "windows per iteration (per rank)"),
    S("stage1.data_worker", False, FlagOrCount(), "processes preparing windows ahead (true: 1)"),
    S("stage1.compile", False, Flag(), "torch.compile the batched step"),
    S("stage1.nearest", "auto", OneOf("auto", "kdtree", "torch"),
      "nearest body vertex search: KD-trees on the CPU, or exact on the device (\"torch\")"),
    S("stage1.autocast_bf16", False, OneOf(False, True, "auto"),
      "Φ under bfloat16 autocast (\"auto\": where the device has native bf16)"),

    S("stage2.sequences", 24, POSITIVE, "training sequences recorded from Φ"),
    S("stage2.sequence_frames", 60, POSITIVE, "frames per recorded sequence"),
    S("stage2.record_budget_share", 0.5, Number(0.0, 1.0), "most of --max-minutes the recording may take"),
    S("stage2.record_group", 8, POSITIVE, "sequences recorded together (batched path)"),
    S("stage2.iterations", 40000, POSITIVE, "f_LP iterations"),
    S("stage2.lr", 3e-4, Number(above=0), "f_LP Adam learning rate"),
    S("stage2.batch", 64, POSITIVE, "windows per iteration"),
    S("stage2.window", 8, POSITIVE, "frames per window (f_LP fed its own predictions)"),
    S("stage2.checkpoint_every", 500, POSITIVE, "iterations between checkpoints"),

    S("simsup.teacher", "pleat", OneOf("pleat", "blender"),
      "the simulator that makes the data: Pleat's (pleat.sim) or Blender's cloth (bpy; its one material)"),
    S("simsup.segment_frames", 90, Integer(2), "frames per simulated segment"),
    S("simsup.repeats", 4, POSITIVE, "rounds over the (clip, variant) pairs"),
    S("simsup.variants", list(VARIANTS[:5]), ListOf(OneOf(*VARIANTS), min_length=1), "clip variants simulated"),
    S("simsup.exclude_sources", [], ListOf(Text()), "leave out the training clips of these motion folders (e.g. "
      "deepmimic_github), and their segments in --data; the validation clips stay"),
    S("simsup.beta_scale", 1.0, Number(0.0), "β ~ N(0, beta_scale²) per component"),
    S("simsup.beta_max", 3.0, Number(0.0), "β clipped to ±beta_max"),
    S("simsup.default_material_share", 0.5, Number(0.0, 1.0), "share of segments at the default material"),
    S("simsup.simulate_share", 0.6, Number(0.0, 1.0), "share of --max-minutes for simulating"),
    S("simsup.max_segments", 0, COUNT, "simulate at most N training segments (0: the whole plan)"),
    S("simsup.data_segments", 0, COUNT, "with --data: use N of its training segments, evenly spaced (0: all)"),
    S("simsup.skip_segments", 0, COUNT, "skip the plan's first N segments (another machine simulated them)"),
    S("simsup.validation_frames", 60, POSITIVE, "frames per validation clip"),
    S("simsup.validation_limit", 0, COUNT, "use the first N validation clips (0: all)"),
    S("simsup.skip_validation", False, Flag(), "simulate no validation clips (a second data machine)"),
    S("simsup.export_only", False, Flag(), "stop after --export (no fit)"),
    S("simsup.tier", "large", TierName(), "sizes of the fitted model"),
    S("simsup.ensemble_members", 1, POSITIVE, "fits averaged into the model"),
    S("simsup.member_tier", "member", TierName(), "sizes of each averaged fit"),
    S("simsup.students", 0, COUNT, "students that replace the fit (0: none)"),
    S("simsup.tier_teacher_frames", 0, COUNT, "unsimulated frames the fit labels for its students and tiers"),
    S("simsup.second_students", 0, COUNT, "a second round of smaller students (0: none)"),
    S("simsup.second_student_tier", "small", TierName(), "sizes of the second round of students"),
    S("simsup.fit_workers", 1, POSITIVE, "fits side by side on a CPU"),
    S("simsup.input_noise", 0.0, Number(0.0), "noise on f_LP's inputs, fraction of each input's spread"),
    S("simsup.latent_noise", 0.0, Number(0.0), "noise on each window's starting latent, fraction of its spread"),
    S("simsup.iterations", 20000, POSITIVE, "f_LP iterations of each fit"),
    S("simsup.dec_iterations", 5000, COUNT, "f_dec iterations of each fit"),
    S("simsup.lr", 1e-3, Number(above=0), "Adam learning rate of the fits"),
    S("simsup.batch", 64, POSITIVE, "windows per iteration"),
    S("simsup.window", 8, POSITIVE, "frames per window"),
    S("simsup.latent_velocity", 0, COUNT, "latent components that carry the change of the largest ones since the "
      "last frame (0: none)"),
    S("simsup.fp16", True, Flag(), "pack weights as fp16"),
    S("simsup.weight_by_energy", False, Flag(), "weight each latent component's error by its variance"),
    S("simsup.onnx", False, Flag(), "embed the MLPs as ONNX in the asset"),
    S("simsup.contact_iterations", 0, COUNT, "contact-aware fine-tune iterations after the fit (0: none)"),
    S("simsup.contact_weight", 30.0, Number(0.0), "weight of the fine-tune's contact term"),
    S("simsup.contact_eps_m", 2e-3, Number(0.0), "fine-tune's clearance from the body, m"),
    S("simsup.contact_lr", 1e-4, Number(above=0), "fine-tune's Adam learning rate"),
    S("simsup.contact_strain_weight", 0.0, Number(0.0), "weight of the fine-tune's edge-length term (loose cloth: "
      "keeps a skirt's predicted edges at the simulated lengths; 0: off)"),
    S("simsup.contact_candidates", 0, Integer(0, 16), "body-contact candidates per vertex from the simulated frames "
                                                      "(0: none)"),

    S("ablation.iterations", 6000, POSITIVE, "ablation iterations"),
    S("ablation.lr", 2e-4, Number(above=0), "ablation Adam learning rate"),
    S("ablation.batch", 4, POSITIVE, "windows per iteration"),
    S("ablation.checkpoint_every", 100, POSITIVE, "iterations between checkpoints"),
)
del S
BY_KEY = {s.key: s for s in SETTINGS}
SECTIONS = tuple(dict.fromkeys(s.key.split(".")[0] for s in SETTINGS if "." in s.key))


# ---- building a config -----------------------------------------------------------------------------------------------
def _copy(v):
    return json.loads(json.dumps(v))


def defaults():
    """The nested config of the declared defaults."""
    cfg = {}
    for s in SETTINGS:
        _put(cfg, s.key, _copy(s.default))
    return cfg


def _put(cfg, key, value):
    *sections, name = key.split(".")
    node = cfg
    for part in sections:
        node = node.setdefault(part, {})
    node[name] = value


def get(cfg, key):
    node = cfg
    for part in key.split("."):
        node = node[part]
    return node


def nearest(key):
    """The declared key closest to `key` (difflib), or None: a misspelt key, or a right name in the wrong section."""
    close = difflib.get_close_matches(key, BY_KEY, n=1, cutoff=0.6)
    if close:
        return close[0]
    name = key.rsplit(".", 1)[-1]
    by_name = [k for k in BY_KEY if k.rsplit(".", 1)[-1] == name]
    if by_name:
        return by_name[0]
    close = difflib.get_close_matches(name, [k.rsplit(".", 1)[-1] for k in BY_KEY], n=1, cutoff=0.7)
    return next((k for k in BY_KEY if close and k.rsplit(".", 1)[-1] == close[0]), None)


def check(key, value, source=None):
    """`value` for `key`, checked against the declaration (ints given for a number become floats); SettingError
    naming the key and its range otherwise. `source`: the file or option it came from, for the message."""
    setting = BY_KEY.get(key)
    if setting is None:
        near = nearest(key)
        hint = f"did you mean {near}?" if near else f"the sections are {', '.join(SECTIONS)}"
        raise SettingError(source, f"unknown setting {key}; {hint} (pleat-train config lists them)")
    try:
        return setting.values.check(value)
    except ValueError as exc:
        raise SettingError(source, f"{key} = {json.dumps(value)}: must be {exc}") from None


def flatten(doc, source=None, prefix=""):
    """{"stage1": {"lr": 0.1}} or {"stage1.lr": 0.1} → {"stage1.lr": 0.1}. A section given as a whole (a dict for a
    section name) sets each of its keys; a dict for anything else is an unknown or misplaced key."""
    flat = {}
    for key, value in doc.items():
        full = prefix + str(key)
        if isinstance(value, dict) and full in SECTIONS:
            flat.update(flatten(value, source, full + "."))
        else:
            flat[full] = value
    return flat


def apply(cfg, values, source=None):
    """Checked `values` ({key: value}, dotted keys or sections) written into the nested `cfg`."""
    for key, value in flatten(values, source).items():
        _put(cfg, key, check(key, value, source))
    return cfg


def preset_path(preset=None, path=None):
    if path:
        return Path(path)
    src = PRESETS_DIR / f"{preset}.json"
    if not src.is_file():
        known = ", ".join(sorted(p.stem for p in PRESETS_DIR.glob("*.json")))
        raise SettingError(src, f"no preset {preset!r}; the presets are {known} (or --config FILE)")
    return src


def read_preset(preset=None, path=None):
    """The preset file's overrides, flat ({"stage1.lr": 2e-4, ...}), checked."""
    src = preset_path(preset, path)
    try:
        doc = json.loads(src.read_text())
    except json.JSONDecodeError as exc:
        raise SettingError(src, f"not JSON: {exc}") from None
    if not isinstance(doc, dict):
        raise SettingError(src, "a preset is a JSON object of settings")
    flat = flatten(doc, src)
    for key, value in flat.items():
        flat[key] = check(key, value, src)
    flat.setdefault("preset", src.stem)
    return flat


def resolve(preset=None, path=None, overrides=None):
    """The config a run uses: the declared defaults, then the preset's (or the file's) values, then `overrides`
    ({"stage1.iterations": 50, ...}). A nested dict holding every declared key."""
    cfg = defaults()
    apply(cfg, read_preset(preset, path), preset_path(preset, path))
    apply(cfg, overrides or {}, "--set")
    _check_together(cfg, "--set" if overrides else preset_path(preset, path))
    return cfg


def _check_together(cfg, source):
    """What one key's range cannot say: the message-passing schedule names levels the hierarchy has."""
    m = cfg["model"]
    if max(m["mp_schedule"]) >= m["mp_levels"]:
        raise SettingError(source, f"model.mp_schedule = {json.dumps(m['mp_schedule'])}: its levels must be below "
                                   f"model.mp_levels = {m['mp_levels']}")


def complete(cfg):
    """A stored config (a checkpoint's, a run folder's) with every declared key it lacks set to the declared
    default, in place (the same dict is returned). Keys no longer declared are kept as they are: a stored run is
    read, not judged."""
    for s in SETTINGS:
        *sections, name = s.key.split(".")
        node = cfg
        for part in sections:
            node = node.setdefault(part, {})
        if name not in node:
            node[name] = _copy(s.default)
    return cfg


def origins(preset=None, path=None, overrides=None):
    """Where each key's resolved value comes from: "default" (declared), the preset's file name where it sets
    another value, or "--set"."""
    src = preset_path(preset, path)
    out = {s.key: "default" for s in SETTINGS}
    out.update({k: src.name for k, v in read_preset(preset, path).items() if v != BY_KEY[k].default})
    out.update({k: "--set" for k in flatten(overrides or {})})
    return out


def parse_set(items):
    """--set KEY=JSON items → {key: value}, each checked against its declaration (SettingError otherwise)."""
    out = {}
    for item in items:
        key, eq, text = item.partition("=")
        if not eq or not key:
            raise SettingError("--set", f"{item!r}: needs KEY=JSON, e.g. stage1.iterations=50")
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            raise SettingError("--set", f"{item}: the value is not JSON (a string needs quotes: "
                                        f"'{key}=\"...\"')") from None
        for k, v in flatten({key: value}).items():
            out[k] = check(k, v, "--set")
    return out


# ---- showing a config ------------------------------------------------------------------------------------------------
def _json(v):
    return json.dumps(v, separators=(", ", ": "))


def describe(cfg, origin=None):
    """The resolved config as text: one line per key with its value, where the value comes from and what it means."""
    width = max(len(k) for k in BY_KEY)
    lines, section = [], None
    for s in SETTINGS:
        top = s.key.split(".")[0] if "." in s.key else ""
        if top != section:
            section = top
            lines.append(f"\n[{top}]" if top else "[top level]")
        where = f" ({origin[s.key]})" if origin and origin[s.key] != "default" else ""
        lines.append(f"  {s.key:<{width}}  {_json(get(cfg, s.key))}{where}")
        lines.append(f"  {'':<{width}}    {s.meaning}; {s.values.text}")
    return "\n".join(lines).lstrip("\n")


def markdown(presets=("default", "tiny")):
    """The table of docs/settings.md: each key, what a preset that leaves it out gets, each preset's
    value where it sets another, the values it takes and its meaning."""
    values = {p: read_preset(p) for p in presets}
    head = ["key", "unset"] + list(presets) + ["values", "meaning"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for s in SETTINGS:
        cells = [f"`{s.key}`", f"`{_json(s.default)}`"]
        for p in presets:
            v = values[p].get(s.key, s.default)
            cells.append("" if v == s.default or s.key == "preset" else f"`{_json(v)}`")
        cells += [s.values.text.replace("|", "\\|"), s.meaning.replace("|", "\\|")]
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)
