"""The cloth and collision settings the add-on's scene starts from: a light shirt, which the artist tunes as usual.
No bpy here: Blender as the teacher keys its cached simulations by these values (pleat.eval.reference.cache_key),
so a changed default simulates anew instead of reading simulations made with the old one.

Lengths in metres (the scene divides by its unit), stiffnesses in Blender's own units.
"""
CLOTH = dict(
    quality=10,                      # solver steps per frame
    air_damping=1.0,
    tension_stiffness=15.0,
    compression_stiffness=15.0,
    shear_stiffness=5.0,
    bending_stiffness=0.05,
    # Blender repels the cloth at the body's outer thickness plus the cloth's own collision distance. At 4 mm each
    # a shirt rides up the torso with every arm swing and stays there (10-20 cm over a 2 s clip); at 1 mm each it
    # stays where the body carries it (docs/accuracy.md, "A second teacher").
    collision_distance_m=0.001,
    self_collision=False,
)
BODY_COLLISION = dict(
    thickness_outer_m=0.001,         # see CLOTH's collision_distance_m
    thickness_inner_m=0.01,
    cloth_friction=5.0,
)


def fingerprint():
    """Everything above, for a cache key."""
    return dict(cloth=CLOTH, body=BODY_COLLISION)
