// Internal: the batched jobs — the MLP job and the blend-shape job of jobs.h over many instances of one asset at once
// (plStepInstances, batch.c). Same conventions as jobs.h: structs of spans, _Validate (non-zero = valid) and _Run
// (validates, never allocates); each instance b has its own spans, so the instances' own buffers are read and written
// in place. Per instance the results are bit-identical to the single-instance job run with the matching kernels
// (kernels_batch.h says why).
#ifndef PLEAT_JOBS_BATCH_H
#define PLEAT_JOBS_BATCH_H
#include "jobs.h"
#include "kernels/kernels_batch.h"

// ---- mlp_batch.c: a chain of Linear layers for batch_count inputs, the weights of a layer read once per batch ----

typedef struct plMlpBatchJob
{
	const plLayer* layers;
	uint32_t layer_count;
	uint32_t activation;           // PLEAT_ACTIVATION_RELU or _SILU
	uint32_t batch_count;          // 1..PLEAT_BATCH_MAX
	const plConstSpan* inputs;     // [batch_count] each [layers[0].in_count] floats, packed
	const plSpan* outputs;         // [batch_count] each [layers[last].out_count] floats, packed
	const plSpan* scratch;         // [batch_count] each [2 · widest hidden layer] floats, packed (ping-pong, as the
	                               // single job's scratch)
	const plBatchKernels* kernels;
	const plTaskRunner* runner;    // optional: the rows of each layer are split over workers
	// Optional (NULL = none): [lanes_floats] floats, 64-byte aligned, for kernels->mat_mat_lanes — the inputs, the
	// hidden layers and the outputs transposed, sixteen instances per vector, from the first layer to the last
	// (plMlpBatchLanesFloats says how many; with fewer, or no lanes kernel, the job runs mat_mat per layer).
	float* lanes;
	size_t lanes_floats;
	// The single-stream int8 mat-vec (plKernels.mat_vec_int8), which int8 layers run per instance (the same bits as
	// plInstance_Step); needed only where a layer is int8.
	plMatVecInt8Fn* mat_vec_int8;
	// Optional (NULL, NULL: each instance through mat_vec_int8): plKernels.mat_mat_int8 and quantise_int8, which run an
	// int8 layer for the batch at once, each instance's input quantised once into the lanes scratch (so only with it).
	plMatMatInt8Fn* mat_mat_int8;
	plQuantiseInt8Fn* quantise_int8;
} plMlpBatchJob;

int plMlpBatchJob_Validate( const plMlpBatchJob* job );
plResult plMlpBatchJob_Run( const plMlpBatchJob* job );
// Floats of lanes scratch a job with these layers needs for batch_count instances (PLEAT_BATCH_MAX for any batch).
size_t plMlpBatchLanesFloats( const plLayer* layers, uint32_t layer_count, uint32_t batch_count );
// Floats of lanes scratch the held inputs of these layers' int8 ones take for batch_count instances (0: none int8).
size_t plMlpBatchHeldFloats( const plLayer* layers, uint32_t layer_count, uint32_t batch_count );

// ---- blend_shapes_batch.c: T_def = shaped template + Σ_j w_j D_j over a vertex range, for batch_count instances ----

typedef struct plBlendShapesBatchJob
{
	uint32_t batch_count;                // 1..PLEAT_BATCH_MAX
	const plConstSpan* shaped_templates; // [batch_count] each [N] xyz, packed (stride 12), metres
	const plConstSpan* weights;          // [batch_count] each [D] floats, packed
	const plSpan* outputs;               // [batch_count] each [N] xyz, packed (stride 12)
	plBlendShapes blend_shapes;          // [D][N][3] fp32, fp16 or int8, shared by the batch (int8: the weights
	                                     // carry the scales, plFoldShapeScales)
	uint32_t vertex_count;               // N
	uint32_t vertex_begin, vertex_end;
	const plBatchKernels* kernels;
} plBlendShapesBatchJob;

int plBlendShapesBatchJob_Validate( const plBlendShapesBatchJob* job );
plResult plBlendShapesBatchJob_Run( const plBlendShapesBatchJob* job );

#endif
