// The network rate decision (docs/inputs.md, "Network update rate"): the networks run on a step unless a rate is set
// and less than its interval has gathered since their last update; when they run, their dt is all of that time, so
// they see a pose history at their own rate. The numpy twin is tools/pleat/reference/network_rate.py.
#include "jobs.h"

plNetworkUpdate plDecideNetworkUpdate( double network_interval_s, double network_pending_s, float dt_s, int first_frame,
									   float dt_min_s, float dt_max_s )
{
	plNetworkUpdate update;
	// 1e-6 relative slack: 25 Hz under a 100 fps loop gathers 4 × (0.01 as a float), a rounding error short of 1/25;
	// without the slack the networks would wait for a fifth step.
	update.run = network_interval_s <= 0.0 || first_frame ||
				 network_pending_s + dt_s >= network_interval_s * ( 1.0 - 1e-6 );
	update.dt_s = update.run ? network_pending_s + dt_s : dt_s;
	update.dt_clamped = 0;
	if ( update.run && update.dt_s < dt_min_s )
	{
		update.dt_s = dt_min_s;
		update.dt_clamped = 1;
	}
	else if ( update.run && update.dt_s > dt_max_s )
	{
		update.dt_s = dt_max_s;
		update.dt_clamped = 1;
	}
	return update;
}
