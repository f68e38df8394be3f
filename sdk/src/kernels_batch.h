// Internal: the batched twins of the MLP and blend-shape kernels (kernels.h), for plStepInstances (batch.c). Many
// instances of one asset are evaluated together, so a weight row or a blend-shape tile read from memory once serves
// every instance of the batch: the mat-vec becomes a matrix-matrix product, the blend a small GEMM.
//
// Bit-identical by construction: each batched kernel is the twin of one single-instance kernel and performs, for every
// (instance, output) pair, exactly the arithmetic of that kernel — the same operations on the same operands in the
// same order, only interleaved with other instances' (independent) operations:
//     plMatMat_Scalar          ↔ plMatVec_Scalar         one float sum per row, c ascending, then + bias
//     plMatMat_Avx2            ↔ plMatVec_Avx2           two 8-wide FMA chains (even / odd 8-blocks of each 16-step),
//                                                         the 8-wide step into the first, their sum, the horizontal
//                                                         sum, a scalar fmaf tail, then + bias
//     plBlendShapesBatch_Scalar ↔ plBlendShapes_Scalar   per element base, then += w_j · D_j, j ascending (two roundings)
//     plBlendShapesBatch_Avx2   ↔ plBlendShapes_Avx2     per element base, then fma(w_j, D_j, ·), j ascending
// test_batched_kernels_match_single checks each pair bit for bit.
#ifndef PLEAT_KERNELS_BATCH_H
#define PLEAT_KERNELS_BATCH_H
#include "kernels.h"

#include <stdint.h>

// The most instances one batched kernel call takes (the job and plStepInstances cut larger groups).
#define PLEAT_BATCH_MAX 64

// out[b][r] = bias[r] + Σ_c W[r][c] · x[b][c] for rows [row_begin, row_end) and b < batch_count; W is [rows][in]
// row-major, fp32 or fp16 (read once per call from memory, then from cache for every b).
typedef void plMatMatFn( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
						 int weight_fp16, const float* bias, uint32_t in_count, uint32_t row_begin, uint32_t row_end );
// out[b][v] = base[b][v] + Σ_j weights[b][j] · shapes[j][v] for vertices [v_begin, v_end) and b < batch_count;
// shapes is [D][N][3], fp32 or fp16; out[b] may not alias base[b].
typedef void plBlendShapesBatchFn( float* const* out, const float* const* base, const float* const* weights,
								   uint32_t batch_count, const void* shapes, int shapes_fp16, uint32_t blend_count,
								   uint32_t vertex_count, uint32_t v_begin, uint32_t v_end );

typedef struct plBatchKernels
{
	plMatMatFn* mat_mat;
	plBlendShapesBatchFn* blend_shapes_batch;
} plBatchKernels;

void plMatMat_Scalar( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
					  int weight_fp16, const float* bias, uint32_t in_count, uint32_t row_begin, uint32_t row_end );
void plBlendShapesBatch_Scalar( float* const* out, const float* const* base, const float* const* weights,
								uint32_t batch_count, const void* shapes, int shapes_fp16, uint32_t blend_count,
								uint32_t vertex_count, uint32_t v_begin, uint32_t v_end );
#if defined( PLEAT_HAVE_AVX2 )
void plMatMat_Avx2( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
					int weight_fp16, const float* bias, uint32_t in_count, uint32_t row_begin, uint32_t row_end );
void plBlendShapesBatch_Avx2( float* const* out, const float* const* base, const float* const* weights,
							  uint32_t batch_count, const void* shapes, int shapes_fp16, uint32_t blend_count,
							  uint32_t vertex_count, uint32_t v_begin, uint32_t v_end );
#endif

// The batched twins of the kernels a context chose (plSelectKernels): each entry matches the single-instance kernel in
// the same slot, so a batch gives what stepping each instance alone gives. Returns 0 if a kernel has no twin.
int plSelectBatchKernels( const plKernels* kernels, plBatchKernels* out );

#endif
