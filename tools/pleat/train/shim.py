"""The model shim: what core.LatentPredictor, core.normalisation and core.network_weights read of a Setup, at another
tier's sizes. Distillation, the ensemble and the simsup run folder all build networks of a tier from a Setup made for
another size; this module sits below them so that none needs another for it."""
from types import SimpleNamespace


def model_shim(setup, L, D, lp_hidden, dec_hidden, activation, teacher_L):
    """What core.LatentPredictor / core.normalisation / core.network_weights read of a Setup, at the tier's sizes."""
    model = dict(setup.cfg["model"], latent=L, blend=D, lp_hidden=list(lp_hidden), dec_hidden=list(dec_hidden),
                 activation=activation, blend_init_m=0.0)
    return SimpleNamespace(cfg=dict(setup.cfg, model=model), L=L, input_count=setup.input_count - teacher_L + L)
