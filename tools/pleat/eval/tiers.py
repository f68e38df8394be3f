"""The four quality tiers of a garment model, as data (docs/pareto.md).

Each tier fixes what sets the runtime's step cost: mesh resolution N, latent size L, blend-shape count D and the two
MLPs' hidden widths. `large` is the shipped default t-shirt (the 1k t-shirt, data/garments/tshirt_1k.npz, with the
paper's inference sizes L = D = 128, f_LP 3×512, f_dec 2×512): the simulator-supervised recipe fits two models at the
`member` sizes and packs their mean at these sizes (pleat.train.ensemble; docs/training.md). The smaller tiers are
distilled from it (`pleat-train simsup-tiers`): smaller L, D and widths, and for `xsmall` a coarser remesh of the
same garment (the 1k mesh's skinning + normals alone cost more than a tenth of large's step), so that the four span
more than 10× in step time. A tier with `mean_of` is the mean of two students at that tier's sizes (seeds s, s + 1)
packed as one network of the summed widths, whose zero blocks the runtime skips: two small students averaged are
0.6 mm closer to the reference than one network at the `member` sizes (3×256 / 2×256), at less cost
(CHANGELOG.md, "Training"). `asset` is where each ships; `member` ships nowhere. `training_overrides(name)`
gives the `--set` overrides for pleat-train's config if a tier is trained from scratch instead.
"""
from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Tier:
    name: str
    vertices: int            # garment mesh resolution N (the t-shirt's remesh target)
    latent: int              # L
    blend: int               # D
    lp_hidden: tuple         # latent-predictor hidden widths
    dec_hidden: tuple        # decoder hidden widths
    activation: str = "relu"
    asset: str = ""          # shipped asset, relative to the repository root
    distilled: bool = True   # False: trained by the two stages itself (the default asset)
    mean_of: str = ""        # the mean of two students at this tier's sizes (pleat.train.ensemble)

    def mlp_macs(self, input_joints=19, betas=10):
        """Multiply-accumulates of f_LP and f_dec per step; for a mean of two students, both members' (the runtime
        skips the zero blocks between them)."""
        if self.mean_of:
            return 2 * tier(self.mean_of).mlp_macs(input_joints, betas)
        from pleat.garment_asset import input_count_without_latent
        I = self.latent + input_count_without_latent(input_joints, betas)
        lp = [I, *self.lp_hidden, self.latent]
        dec = [self.latent, *self.dec_hidden, self.blend]
        return sum(a * b for a, b in zip(lp[:-1], lp[1:])) + sum(a * b for a, b in zip(dec[:-1], dec[1:]))

    def macs(self, input_joints=19, betas=10, influences=4):
        """Multiply-accumulates per step: MLPs + blend shapes (D·3N) + skinning (12·K·N); a cost model only."""
        return (self.mlp_macs(input_joints, betas) + self.blend * 3 * self.vertices
                + 12 * influences * self.vertices)


TIERS = (
    Tier("xsmall", vertices=150, latent=16, blend=16, lp_hidden=(64,), dec_hidden=(64,),
         asset="assets/tshirt_xsmall.pleat"),
    Tier("small", vertices=1004, latent=32, blend=32, lp_hidden=(128, 128), dec_hidden=(128,),
         asset="assets/tshirt_small.pleat"),
    Tier("medium", vertices=1004, latent=64, blend=64, lp_hidden=(256, 256), dec_hidden=(256,),
         asset="assets/tshirt_medium.pleat", mean_of="small"),
    Tier("member", vertices=1004, latent=64, blend=64, lp_hidden=(256, 256, 256), dec_hidden=(256, 256)),
    Tier("large", vertices=1004, latent=128, blend=128, lp_hidden=(512, 512, 512), dec_hidden=(512, 512),
         asset="assets/tshirt.pleat", distilled=False),
)
BY_NAME = {t.name: t for t in TIERS}
SHIPPED = tuple(t for t in TIERS if t.asset)     # the tier ladder, cheapest first


def packed(name, count):
    """The sizes of `count` networks of tier `name` packed as one (pleat.train.ensemble: summed widths, equal blocks
    the runtime skips between), named "<count>x<name>"; e.g. packed("small", 6) for the six small students of
    CHANGELOG.md, "Training" (larger ensembles and more teacher-only motion, tried and not kept)."""
    t = tier(name)
    return Tier(f"{count}x{t.name}", vertices=t.vertices, latent=count * t.latent, blend=count * t.blend,
                lp_hidden=tuple(count * w for w in t.lp_hidden), dec_hidden=tuple(count * w for w in t.dec_hidden),
                activation=t.activation)


def tier(name):
    """A tier by name; "<count>x<name>" is `count` networks of that tier packed as one (packed)."""
    count, _, member = name.partition("x") if name not in BY_NAME else ("", "", "")
    if count.isdigit() and int(count) > 0 and member in BY_NAME:
        return packed(member, int(count))
    try:
        return BY_NAME[name]
    except KeyError:
        raise ValueError(f"unknown tier {name!r}; known: {', '.join(BY_NAME)} (or <count>x<one of them>)") from None


def training_overrides(name):
    """pleat-train `--set KEY=JSON` overrides that give a run this tier's sizes."""
    t = tier(name)
    return {"garment_vertices": t.vertices, "model.latent": t.latent, "model.blend": t.blend,
            "model.lp_hidden": list(t.lp_hidden), "model.dec_hidden": list(t.dec_hidden),
            "model.activation": t.activation}


def random_tier_weights(name, seed=0):
    """A weights dict with this tier's sizes and random, well-behaved weights (pleat.reference.golden.random_weights):
    what the step costs, before any training."""
    from pleat.reference.golden import random_weights
    t = tier(name)
    w = random_weights(vertices=t.vertices, latent=t.latent, blend=t.blend, lp_hidden=t.lp_hidden,
                       dec_hidden=t.dec_hidden, seed=seed, activation=t.activation,
                       garment_name=f"tier-{t.name}-random")
    return w


def as_dict(t):
    d = asdict(t)
    d["lp_hidden"], d["dec_hidden"] = list(t.lp_hidden), list(t.dec_hidden)
    return d
