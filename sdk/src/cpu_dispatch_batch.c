// The batched kernels follow the context's choice (cpu_dispatch.c): each single-instance kernel has batched twins with
// the same arithmetic, so a batch gives what stepping each instance alone gives on that context. The twins of the AVX2
// kernels come in two widths: AVX2 itself and, where the CPU has AVX-512 F/VL/BW/DQ, AVX-512 for the networks and
// the blend (kernels_batch.h).
#include "kernels_batch.h"

#include <stddef.h>

plBatchIsa g_plBatchIsaLimit = PLEAT_BATCH_ISA_AVX512;

int plCpuHasAvx512Batch( void )
{
#if defined( PLEAT_HAVE_AVX512 ) && ( defined( __GNUC__ ) || defined( __clang__ ) )
	__builtin_cpu_init();
	// libgcc / compiler-rt report AVX-512 only when the OS saves the ZMM state (XCR0) as well.
	return __builtin_cpu_supports( "avx512f" ) && __builtin_cpu_supports( "avx512vl" ) &&
		   __builtin_cpu_supports( "avx512bw" ) && __builtin_cpu_supports( "avx512dq" ) &&
		   __builtin_cpu_supports( "avx2" ) && __builtin_cpu_supports( "fma" );
#else
	return 0;
#endif
}

size_t plNormalsBatchScratchFloats( uint32_t vertex_count, uint32_t lanes )
{
	if ( lanes <= 1 )
	{
		return (size_t)vertex_count * 4; // the scalar scatter's [N][4] sums
	}
	// positions and sums, [N'][3][lanes] each with N' = N rounded up to whole blocks of `lanes` vertices (the lane
	// transposes move whole blocks: the last one writes and reads past N), each starting on a 64-byte line
	size_t blocks = ( (size_t)vertex_count + lanes - 1 ) / lanes;
	size_t one = blocks * lanes * 3 * lanes;
	one = ( one + 15 ) & ~(size_t)15;
	return 2 * one;
}

// A single-instance kernel set (the kernels with batched twins) and its twins.
typedef struct plKernelTwins
{
	plMatVecFn* mat_vec;
	plBlendShapesFn* blend_shapes;
	plSkinningFn* skinning;
	plPoseBodyPointsFn* pose_body_points;
	plNormalsScatterFn* normals_scatter;
	plBatchKernels batch;
} plKernelTwins;

static const plKernelTwins s_plKernelTwins[] = {
	{ plMatVec_Scalar, plBlendShapes_Scalar, plSkinning_Scalar, plPoseBodyPoints_Scalar, plNormalsScatter_Scalar,
	  { plMatMat_Scalar, NULL, plBlendShapesBatch_Scalar, plSkinningBatch_Scalar, plBodyContactFastBatch_Scalar, NULL,
		plNormalsBatch_Scalar, 1, "scalar" } },
#if defined( PLEAT_HAVE_AVX2 )
	{ plMatVec_Avx2, plBlendShapes_Avx2, plSkinning_Avx2, plPoseBodyPoints_Avx2, plNormalsScatter_Avx2,
	  { plMatMat_Avx2, NULL, plBlendShapesBatch_Avx2, plSkinningBatch_Avx2, plBodyContactFastBatch_Avx2,
		plBodyContactBatch_Avx2, plNormalsBatch_Avx2, 8, "avx2+fma+f16c" } },
#endif
};

int plSelectBatchKernelsUpTo( const plKernels* kernels, plBatchIsa limit, plBatchKernels* out )
{
	const plBatchKernels none = { NULL, NULL, NULL, NULL, NULL, NULL, NULL, 1, "scalar" };
	*out = none;
	for ( size_t i = 0; i < sizeof( s_plKernelTwins ) / sizeof( s_plKernelTwins[0] ); ++i )
	{
		const plKernelTwins* t = &s_plKernelTwins[i];
		if ( kernels->mat_vec == t->mat_vec && kernels->blend_shapes == t->blend_shapes &&
			 kernels->skinning == t->skinning && kernels->pose_body_points == t->pose_body_points &&
			 kernels->normals_scatter == t->normals_scatter )
		{
			*out = t->batch;
			break;
		}
	}
#if defined( PLEAT_HAVE_AVX512 )
	// The AVX2 set's wider twins for the networks and the blend, where the CPU runs them.
	if ( out->mat_mat == plMatMat_Avx2 && limit >= PLEAT_BATCH_ISA_AVX512 && plCpuHasAvx512Batch() )
	{
		out->mat_mat = plMatMat_Avx512;
		out->mat_mat_lanes = plMatMatLanes_Avx512;
		out->blend_shapes_batch = plBlendShapesBatch_Avx512;
		out->isa = "avx512f+vl+bw+dq (mlp, blend) + avx2+fma (skinning, body contact, normals)";
	}
#endif
	(void)limit;
	return out->mat_mat != NULL && out->blend_shapes_batch != NULL && out->skinning_batch != NULL &&
		   out->body_contact_fast_batch != NULL && out->normals_batch != NULL;
}

int plSelectBatchKernels( const plKernels* kernels, plBatchKernels* out )
{
	return plSelectBatchKernelsUpTo( kernels, g_plBatchIsaLimit, out );
}
