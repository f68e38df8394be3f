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
	// positions and sums, [N][3][lanes] each, each starting on a 64-byte line
	size_t one = (size_t)vertex_count * 3 * lanes;
	one = ( one + 15 ) & ~(size_t)15;
	return 2 * one;
}

int plSelectBatchKernelsUpTo( const plKernels* kernels, plBatchIsa limit, plBatchKernels* out )
{
	out->mat_mat = NULL;
	out->mat_mat_lanes = NULL;
	out->blend_shapes_batch = NULL;
	out->skinning_batch = NULL;
	out->body_contact_batch = NULL;
	out->normals_batch = NULL;
	out->geometry_lanes = 1;
	out->isa = "scalar";
	if ( kernels->mat_vec == plMatVec_Scalar && kernels->blend_shapes == plBlendShapes_Scalar &&
		 kernels->skinning == plSkinning_Scalar && kernels->body_contact == plBodyContact_Scalar &&
		 kernels->normals_scatter == plNormalsScatter_Scalar )
	{
		out->mat_mat = plMatMat_Scalar;
		out->blend_shapes_batch = plBlendShapesBatch_Scalar;
		out->skinning_batch = plSkinningBatch_Scalar;
		out->body_contact_batch = plBodyContactBatch_Scalar;
		out->normals_batch = plNormalsBatch_Scalar;
	}
#if defined( PLEAT_HAVE_AVX2 )
	else if ( kernels->mat_vec == plMatVec_Avx2 && kernels->blend_shapes == plBlendShapes_Avx2 &&
			  kernels->skinning == plSkinning_Avx2 && kernels->body_contact == plBodyContact_Avx2 &&
			  kernels->normals_scatter == plNormalsScatter_Avx2 )
	{
		out->mat_mat = plMatMat_Avx2;
		out->blend_shapes_batch = plBlendShapesBatch_Avx2;
		out->skinning_batch = plSkinningBatch_Avx2;
		out->body_contact_batch = plBodyContactBatch_Avx2;
		out->normals_batch = plNormalsBatch_Avx2;
		out->geometry_lanes = 8;
		out->isa = "avx2+fma+f16c";
#if defined( PLEAT_HAVE_AVX512 )
		if ( limit >= PLEAT_BATCH_ISA_AVX512 && plCpuHasAvx512Batch() )
		{
			out->mat_mat = plMatMat_Avx512;
			out->mat_mat_lanes = plMatMatLanes_Avx512;
			out->blend_shapes_batch = plBlendShapesBatch_Avx512;
			out->isa = "avx512f+vl+bw+dq (mlp, blend) + avx2+fma (skinning, body contact, normals)";
		}
#endif
	}
#endif
	(void)limit;
	return out->mat_mat != NULL && out->blend_shapes_batch != NULL && out->skinning_batch != NULL &&
		   out->body_contact_batch != NULL && out->normals_batch != NULL;
}

int plSelectBatchKernels( const plKernels* kernels, plBatchKernels* out )
{
	return plSelectBatchKernelsUpTo( kernels, g_plBatchIsaLimit, out );
}
