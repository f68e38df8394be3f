// The batched twins of each kernel set (kernels_batch.h): each single-instance kernel has batched twins with the same
// arithmetic, so a batch gives what stepping each instance alone gives on that set. The twins of the AVX2 kernels come
// in two widths: AVX2 itself and, in PLEAT_KERNEL_SET_AVX512, AVX-512 for the networks and the blend.
#include "kernels_batch.h"

#include <stddef.h>

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

static const plBatchKernels s_plBatchScalar = { plMatMat_Scalar,
												NULL,
												plBlendShapesBatch_Scalar,
												plSkinningBatch_Scalar,
												plBodyContactFastBatch_Scalar,
												NULL,
												plNormalsBatch_Scalar,
												1,
												"scalar" };
#if defined( PLEAT_HAVE_AVX2 )
static const plBatchKernels s_plBatchAvx2 = { plMatMat_Avx2,
											  NULL,
											  plBlendShapesBatch_Avx2,
											  plSkinningBatch_Avx2,
											  plBodyContactFastBatch_Avx2,
											  plBodyContactBatch_Avx2,
											  plNormalsBatch_Avx2,
											  8,
											  "avx2+fma+f16c" };
#endif
#if defined( PLEAT_HAVE_AVX512 )
// The AVX2 set's wider twins for the networks, the blend and the full body contact (16 instances per lane group);
// skinning, the fast contact and normals run the AVX2 kernels over the group, 8 instances at a time.
static const plBatchKernels s_plBatchAvx512 = { plMatMat_Avx512,
												plMatMatLanes_Avx512,
												plBlendShapesBatch_Avx512,
												plSkinningBatch_Avx2,
												plBodyContactFastBatch_Avx2,
												plBodyContactBatch_Avx512,
												plNormalsBatch_Avx2,
												16,
												"avx512f+vl+bw+dq (mlp, blend, body contact) + avx2+fma (skinning, "
												"normals)" };
#endif

const plBatchKernels* plBatchKernelsOf( plKernelSet set )
{
	switch ( set )
	{
	case PLEAT_KERNEL_SET_SCALAR:
		return &s_plBatchScalar;
#if defined( PLEAT_HAVE_AVX2 )
	case PLEAT_KERNEL_SET_AVX2:
		return &s_plBatchAvx2;
#endif
#if defined( PLEAT_HAVE_AVX512 )
	case PLEAT_KERNEL_SET_AVX512:
		return &s_plBatchAvx512;
#endif
	default:
		return NULL;
	}
}
