"""The network rate decision (docs/inputs.md, "Network update rate"), the twin of sdk/src/network_rate.c: the networks
run on a step unless a rate is set and less than its interval has gathered since their last update; when they run,
their dt is all of that time, clamped to the asset's range."""
from typing import NamedTuple


class NetworkUpdate(NamedTuple):
    run: bool           # the networks run on this step (else the held deformation is skinned with the new pose)
    dt_s: float         # run: all the time since the networks' last update, clamped; else the step's own dt_s
    dt_clamped: bool    # run, and dt_s was clamped to [dt_min_s, dt_max_s]


def decide_network_update(network_interval_s, network_pending_s, dt_s, first_frame, dt_min_s, dt_max_s):
    """network_interval_s: 1 / network_rate_hz (0 = every step); network_pending_s: time gathered since the last
    update; dt_s: this step's dt as the C API's float; first_frame: no history yet (the networks always run then)."""
    # 1e-6 relative slack: 25 Hz under a 100 fps loop gathers 4 × float32(0.01), a rounding error short of 1/25
    run = (network_interval_s <= 0.0 or first_frame
           or network_pending_s + dt_s >= network_interval_s * (1.0 - 1e-6))
    dt = network_pending_s + dt_s if run else dt_s
    if run and dt < dt_min_s:
        return NetworkUpdate(True, float(dt_min_s), True)
    if run and dt > dt_max_s:
        return NetworkUpdate(True, float(dt_max_s), True)
    return NetworkUpdate(run, dt, False)
