// The batched kernels follow the context's choice (cpu_dispatch.c): each single-instance kernel has one batched twin
// with the same arithmetic, so a batch gives what stepping each instance alone gives on that context.
#include "kernels_batch.h"

#include <stddef.h>

int plSelectBatchKernels( const plKernels* kernels, plBatchKernels* out )
{
	out->mat_mat = NULL;
	out->blend_shapes_batch = NULL;
	if ( kernels->mat_vec == plMatVec_Scalar )
	{
		out->mat_mat = plMatMat_Scalar;
	}
	if ( kernels->blend_shapes == plBlendShapes_Scalar )
	{
		out->blend_shapes_batch = plBlendShapesBatch_Scalar;
	}
#if defined( PLEAT_HAVE_AVX2 )
	if ( kernels->mat_vec == plMatVec_Avx2 )
	{
		out->mat_mat = plMatMat_Avx2;
	}
	if ( kernels->blend_shapes == plBlendShapes_Avx2 )
	{
		out->blend_shapes_batch = plBlendShapesBatch_Avx2;
	}
#endif
	return out->mat_mat != NULL && out->blend_shapes_batch != NULL;
}
