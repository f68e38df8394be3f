// The latent guard job: Z_t+1 = clamp(y · z_std + z_mean, z_min, z_max). f_LP predicts the standardised latent y; the
// guard takes it back to latent units and keeps it inside the range the decoder saw in training (ZMIN/ZMAX), so a
// long rollout that drifts cannot feed the decoder or the next X_c a latent it never learned.
#include "jobs.h"

int plLatentGuardJob_Validate( const plLatentGuardJob* job )
{
	return job != NULL && job->z_mean != NULL && job->z_std != NULL && job->z_min != NULL && job->z_max != NULL &&
		   plSpan_ElementwiseFloats( &job->input, &job->output );
}

plResult plLatentGuardJob_Run( const plLatentGuardJob* job )
{
	if ( !plLatentGuardJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	const float* y = (const float*)job->input.ptr;
	float* latent = (float*)job->output.ptr;
	for ( uint32_t i = 0; i < job->input.count; ++i )
	{
		float z = y[i] * job->z_std[i] + job->z_mean[i];
		z = z < job->z_min[i] ? job->z_min[i] : z;
		z = z > job->z_max[i] ? job->z_max[i] : z;
		latent[i] = z;
	}
	return PLEAT_RESULT_OK;
}
