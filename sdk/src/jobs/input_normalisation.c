// The input normalisation job: x = (X_c − x_mean) / x_std per component, with the statistics of X_c over the
// training data that the asset carries (XMEA/XSTD), so f_LP sees inputs on the scale it was trained on.
#include "jobs.h"

int plInputNormalisationJob_Validate( const plInputNormalisationJob* job )
{
	return job != NULL && job->x_mean != NULL && job->x_std != NULL &&
		   plSpan_ElementwiseFloats( &job->input, &job->output );
}

plResult plInputNormalisationJob_Run( const plInputNormalisationJob* job )
{
	if ( !plInputNormalisationJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	const float* x_c = (const float*)job->input.ptr;
	float* x = (float*)job->output.ptr;
	for ( uint32_t i = 0; i < job->input.count; ++i )
	{
		x[i] = ( x_c[i] - job->x_mean[i] ) / job->x_std[i];
	}
	return PLEAT_RESULT_OK;
}
