// Chooses the CPU kernels once per context (CPUID): the single-instance set and its batched twins in one table.
#include "kernels.h"
#include "kernels_batch.h"

plKernelSet plChooseKernels( plKernels* kernels, plKernelSet max_isa )
{
	kernels->mat_vec = plMatVec_Scalar;
	kernels->mat_vec_int8 = plMatVecInt8_Scalar;
	kernels->mat_mat_int8 = plMatMatInt8_Scalar;
	kernels->quantise_int8 = plQuantiseInt8_Scalar;
	kernels->blend_shapes = plBlendShapes_Scalar;
	kernels->skinning = plSkinning_Scalar;
	kernels->face_normals = plFaceNormals_Scalar;
	kernels->normals_gather = plNormalsGather_Scalar;
	kernels->normals_scatter = plNormalsScatter_Scalar;
	kernels->pose_body_points = plPoseBodyPoints_Scalar;
	kernels->body_point_normals = plBodyPointNormals_Scalar;
	kernels->body_contact = plBodyContact_Scalar;
	kernels->body_contact_fast = plBodyContactFast_Scalar;
	kernels->set = PLEAT_KERNEL_SET_SCALAR;
#if defined( PLEAT_HAVE_AVX2 ) && ( defined( __GNUC__ ) || defined( __clang__ ) )
	if ( max_isa >= PLEAT_KERNEL_SET_AVX2 )
	{
		__builtin_cpu_init();
		if ( __builtin_cpu_supports( "avx2" ) && __builtin_cpu_supports( "fma" ) )
		{
			// F16C has no __builtin_cpu_supports name in older GCCs; every AVX2 CPU shipped has it.
			kernels->mat_vec = plMatVec_Avx2;
			kernels->blend_shapes = plBlendShapes_Avx2;
			kernels->skinning = plSkinning_Avx2;
			kernels->face_normals = plFaceNormals_Avx2;
			kernels->normals_gather = plNormalsGather_Avx2;
			kernels->normals_scatter = plNormalsScatter_Avx2;
			kernels->pose_body_points = plPoseBodyPoints_Avx2;
			kernels->body_contact = plBodyContact_Avx2;
			kernels->body_contact_fast = plBodyContactFast_Avx2;
			kernels->body_point_normals = plBodyPointNormals_Avx2;
			kernels->set = PLEAT_KERNEL_SET_AVX2;
			kernels->mat_vec_int8 = plMatVecInt8_Avx2;
			// the AVX2 crowd runs each instance through the single kernel: vpmaddubsw needs the sign trick per row
			// and instance, so sharing a weight load between instances saves little
			kernels->mat_mat_int8 = NULL;
			kernels->quantise_int8 = NULL;
#if defined( PLEAT_HAVE_AVXVNNI )
			if ( plCpuHasAvxVnni() )
			{
				kernels->mat_vec_int8 = plMatVecInt8_AvxVnni;
			}
#endif
			// The single-instance kernels stay AVX2: only the batched networks and blend have AVX-512 twins.
			if ( max_isa >= PLEAT_KERNEL_SET_AVX512 && plBatchKernelsOf( PLEAT_KERNEL_SET_AVX512 ) != NULL &&
				 plCpuHasAvx512Batch() )
			{
				kernels->set = PLEAT_KERNEL_SET_AVX512;
#if defined( PLEAT_HAVE_AVX512VNNI )
				if ( plCpuHasAvx512Vnni() )
				{
					kernels->mat_vec_int8 = plMatVecInt8_Avx512Vnni;
					kernels->mat_mat_int8 = plMatMatInt8_Avx512Vnni;
					kernels->quantise_int8 = plQuantiseInt8_Avx512Vnni;
				}
#endif
			}
		}
	}
#else
	(void)max_isa;
#endif
	kernels->batch = plBatchKernelsOf( kernels->set );
	return kernels->set;
}

uint32_t plInt8MatVecVariants( plMatVecInt8Fn** kernels, const char** names, uint32_t capacity )
{
	uint32_t n = 0;
#define PLEAT_ADD_VARIANT( fn, name )                                                                                \
	if ( n < capacity )                                                                                              \
	{                                                                                                                \
		kernels[n] = fn;                                                                                             \
		names[n] = name;                                                                                             \
		++n;                                                                                                         \
	}
	PLEAT_ADD_VARIANT( plMatVecInt8_Scalar, "scalar" )
#if defined( PLEAT_HAVE_AVX2 ) && ( defined( __GNUC__ ) || defined( __clang__ ) )
	__builtin_cpu_init();
	if ( __builtin_cpu_supports( "avx2" ) && __builtin_cpu_supports( "fma" ) )
	{
		PLEAT_ADD_VARIANT( plMatVecInt8_Avx2, "avx2" )
#if defined( PLEAT_HAVE_AVXVNNI )
		if ( plCpuHasAvxVnni() )
		{
			PLEAT_ADD_VARIANT( plMatVecInt8_AvxVnni, "avx-vnni" )
		}
#endif
#if defined( PLEAT_HAVE_AVX512VNNI )
		if ( plCpuHasAvx512Vnni() )
		{
			PLEAT_ADD_VARIANT( plMatVecInt8_Avx512Vnni, "avx512-vnni" )
		}
#endif
	}
#endif
#undef PLEAT_ADD_VARIANT
	return n;
}
