// The batched MLP job: f_LP or f_dec for many instances of one asset, layer by layer, each layer a matrix-matrix
// product whose weights are read once for the whole batch (kernels_batch.h). With a lanes kernel and scratch the
// whole chain runs transposed (sixteen instances per vector) and only the first input and the last output move
// between the two layouts. plMatMat_Scalar is the specification: per
// (instance, row) exactly plMatVec_Scalar's sum. The activation between layers is the single job's (plApplyActivation).
#include "jobs_batch.h"

void plMatMat_Scalar( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
					  int weight_fp16, const float* bias, uint32_t in_count, uint32_t col_begin, uint32_t col_end,
					  uint32_t row_begin, uint32_t row_end )
{
	for ( uint32_t r = row_begin; r < row_end; ++r )
	{
		for ( uint32_t b = 0; b < batch_count; ++b )
		{
			out[b][r] = plDotRowScalar( x[b] + col_begin, weight, weight_fp16, (size_t)r * in_count + col_begin,
										col_end - col_begin ) +
						bias[r];
		}
	}
}

// One layer's rows [begin, end) for the whole batch: the lanes form (the chain transposed) where yt is set, else each
// instance's own buffers.
typedef struct plMatMatTask
{
	const plBatchKernels* kernels;
	const plLayer* layer;
	float* const* out; // per instance
	const float* const* x;
	uint32_t batch_count;
	float* yt; // lanes form: [group_count][out_count][PLEAT_LANES]
	const float* xt;
	uint32_t group_count;
	uint32_t activation; // lanes form: applied to the task's rows (0: none, the last layer)
	plMatVecInt8Fn* mat_vec_int8; // an int8 layer: the single job's kernel, per instance,
	plMatMatInt8Fn* mat_mat_int8; // or the batched one on the batch's held inputs
	const void* held;             // the block plQuantiseInt8Fn wrote
} plMatMatTask;

// Rows [begin, end) block by block (plLayerBlocks), each over its own column window, as the single job runs them.
static void plMatMatTaskRun( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	const plMatMatTask* t = (const plMatMatTask*)context;
	const plLayer* l = t->layer;
	plLayerBlock blocks[PLEAT_MAX_LAYER_BLOCKS];
	uint32_t block_count = plLayerBlocks( l, blocks );
	for ( uint32_t i = 0; i < block_count; ++i )
	{
		uint32_t rb, re, cb = blocks[i].col_begin, ce = blocks[i].col_end;
		if ( !plBlockRowsWithin( &blocks[i], begin, end, &rb, &re ) )
		{
			continue;
		}
		if ( l->weight_int8 && t->mat_mat_int8 != NULL )
		{
			// the batch at once on the held inputs, over the block's window (packed or in place alike)
			const int8_t* w = l->packed != NULL ? (const int8_t*)l->packed : (const int8_t*)l->weight + cb;
			uint32_t stride = l->packed != NULL ? l->packed_width : l->in_count;
			t->mat_mat_int8( t->out, t->held, t->batch_count, l, w, stride, cb, ce - cb, rb, re );
		}
		else if ( l->weight_int8 )
		{
			// each instance through the single-stream int8 kernel, as plMlpJob runs it: the same bits as one step
			const int8_t* w = (const int8_t*)( l->packed != NULL ? l->packed : l->weight );
			uint32_t stride = l->packed != NULL ? l->packed_width : l->in_count;
			uint32_t wb = l->packed != NULL ? 0 : cb, we = l->packed != NULL ? l->packed_width : ce;
			for ( uint32_t b = 0; b < t->batch_count; ++b )
			{
				const float* x = l->packed != NULL ? t->x[b] + cb : t->x[b];
				t->mat_vec_int8( t->out[b], x, l, w, stride, wb, we, rb, re );
			}
		}
		else if ( t->yt != NULL )
		{
			// the packed copy where the layer has one: each row's window contiguous, one stream for the prefetchers
			// (read in place, the windows' rows alternate with the zero blocks')
			size_t element = l->weight_fp16 ? 2 : 4;
			const void* window = l->packed != NULL ? l->packed : (const char*)l->weight + cb * element;
			size_t stride = l->packed != NULL ? l->packed_width : l->in_count;
			t->kernels->mat_mat_lanes( t->yt, t->xt, t->group_count, window, stride, l->weight_fp16, l->bias,
									   l->in_count, l->out_count, cb, ce, rb, re );
		}
		else
		{
			t->kernels->mat_mat( t->out, t->x, t->batch_count, l->weight, l->weight_fp16, l->bias, l->in_count, cb,
								 ce, rb, re );
		}
	}
	// The activation of the rows just written, per lane group (element-wise: where it runs does not change a bit),
	// on this worker while they are in its cache instead of over the whole layer on the calling thread after it.
	for ( uint32_t g = 0; t->yt != NULL && t->activation != 0 && g < t->group_count; ++g )
	{
		plApplyActivation( t->yt + ( (size_t)g * l->out_count + begin ) * PLEAT_LANES, ( end - begin ) * PLEAT_LANES,
						   t->activation );
	}
}

static uint32_t plWidestHidden( const plLayer* layers, uint32_t layer_count )
{
	uint32_t widest = 0;
	for ( uint32_t i = 0; i + 1 < layer_count; ++i )
	{
		widest = layers[i].out_count > widest ? layers[i].out_count : widest;
	}
	return widest;
}

int plMlpBatchJob_Validate( const plMlpBatchJob* job )
{
	if ( job == NULL || job->layers == NULL || job->layer_count == 0 || job->layer_count > PLEAT_MAX_LAYERS ||
		 job->kernels == NULL || job->kernels->mat_mat == NULL || job->batch_count == 0 ||
		 job->batch_count > PLEAT_BATCH_MAX || job->inputs == NULL || job->outputs == NULL || job->scratch == NULL ||
		 ( job->activation != PLEAT_ACTIVATION_RELU && job->activation != PLEAT_ACTIVATION_SILU ) )
	{
		return 0;
	}
	for ( uint32_t i = 0; i < job->layer_count; ++i )
	{
		const plLayer* l = &job->layers[i];
		if ( l->weight == NULL || l->bias == NULL || l->in_count == 0 || l->out_count == 0 ||
			 ( i > 0 && l->in_count != job->layers[i - 1].out_count ) || !plInt8LayerIsValid( l ) ||
			 ( l->weight_int8 && job->mat_vec_int8 == NULL ) ||
			 ( ( job->mat_mat_int8 == NULL ) != ( job->quantise_int8 == NULL ) ) )
		{
			return 0;
		}
	}
	uint32_t widest = plWidestHidden( job->layers, job->layer_count );
	uint32_t in_count = job->layers[0].in_count, out_count = job->layers[job->layer_count - 1].out_count;
	for ( uint32_t b = 0; b < job->batch_count; ++b )
	{
		if ( !PLEAT_SPAN_HOLDS( job->inputs[b], 4, in_count ) || job->inputs[b].stride_bytes != 4 ||
			 !PLEAT_SPAN_HOLDS( job->outputs[b], 4, out_count ) || job->outputs[b].stride_bytes != 4 ||
			 ( widest != 0 &&
			   ( !PLEAT_SPAN_HOLDS( job->scratch[b], 4, 2 * widest ) || job->scratch[b].stride_bytes != 4 ) ) )
		{
			return 0;
		}
	}
	return 1;
}

// ---- the lanes form (kernels->mat_mat_lanes): the whole chain transposed, sixteen instances per vector ----

static size_t plRoundUp16( size_t floats )
{
	return ( floats + 15 ) & ~(size_t)15;
}

size_t plMlpBatchLanesFloats( const plLayer* layers, uint32_t layer_count, uint32_t batch_count )
{
	uint32_t widest = layer_count > 0 ? layers[0].in_count : 0;
	for ( uint32_t i = 0; i < layer_count; ++i )
	{
		widest = layers[i].out_count > widest ? layers[i].out_count : widest;
	}
	size_t groups = ( batch_count + PLEAT_LANES - 1 ) / PLEAT_LANES;
	return 2 * plRoundUp16( groups * widest * PLEAT_LANES ); // ping and pong
}

// Non-zero if the job can take the lanes form (a lanes kernel, its scratch, enough instances to fill the lanes, fp16
// rows the kernel widens).
static int plUseLanes( const plMlpBatchJob* job )
{
	if ( job->kernels->mat_mat_lanes == NULL || job->lanes == NULL || ( (uintptr_t)job->lanes & 63u ) != 0 ||
		 job->batch_count < PLEAT_LANES / 2 ||
		 job->lanes_floats < plMlpBatchLanesFloats( job->layers, job->layer_count, job->batch_count ) )
	{
		return 0;
	}
	for ( uint32_t i = 0; i < job->layer_count; ++i )
	{
		if ( ( job->layers[i].weight_fp16 && job->layers[i].in_count > PLEAT_LANES_MAX_FP16_COLUMNS ) ||
			 job->layers[i].weight_int8 )
		{
			return 0; // int8 networks run per instance (plMatMatTaskRun)
		}
	}
	return 1;
}

// The inputs of lane groups [begin, end) transposed: xt[g][c][l] = inputs[16 g + l][c], zero in lanes past the batch.
static void plTransposeInputsTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	const plMlpBatchJob* job = (const plMlpBatchJob*)context;
	uint32_t n = job->batch_count, in_count = job->layers[0].in_count;
	for ( uint32_t g = begin; g < end; ++g )
	{
		for ( uint32_t l = 0; l < PLEAT_LANES; ++l )
		{
			uint32_t b = g * PLEAT_LANES + l;
			const float* x = b < n ? (const float*)job->inputs[b].ptr : NULL;
			float* column = job->lanes + (size_t)g * in_count * PLEAT_LANES + l;
			for ( uint32_t c = 0; c < in_count; ++c )
			{
				column[(size_t)c * PLEAT_LANES] = x != NULL ? x[c] : 0.0f;
			}
		}
	}
}

static void plRunLanes( const plMlpBatchJob* job )
{
	uint32_t n = job->batch_count, groups = ( n + PLEAT_LANES - 1 ) / PLEAT_LANES;
	size_t half = job->lanes_floats / 2 & ~(size_t)15;
	float* buffers[2] = { job->lanes, job->lanes + half };
	plRunTask( job->runner, plTransposeInputsTask, groups, 1, (void*)job ); // into buffers[0]
	for ( uint32_t i = 0; i < job->layer_count; ++i )
	{
		const plLayer* layer = &job->layers[i];
		float* yt = buffers[( i + 1 ) & 1u];
		plMatMatTask task = { .kernels = job->kernels,
							  .layer = layer,
							  .yt = yt,
							  .xt = buffers[i & 1u],
							  .group_count = groups,
							  .activation = i + 1 < job->layer_count ? job->activation : 0 };
		plRunTask( job->runner, plMatMatTaskRun, layer->out_count, 64, &task );
	}
	// The outputs back per instance.
	const float* yt = buffers[job->layer_count & 1u];
	uint32_t out_count = job->layers[job->layer_count - 1].out_count;
	for ( uint32_t b = 0; b < n; ++b )
	{
		float* y = (float*)job->outputs[b].ptr;
		const float* row = yt + (size_t)( b / PLEAT_LANES ) * out_count * PLEAT_LANES + b % PLEAT_LANES;
		for ( uint32_t r = 0; r < out_count; ++r )
		{
			y[r] = row[(size_t)r * PLEAT_LANES];
		}
	}
}

size_t plMlpBatchHeldFloats( const plLayer* layers, uint32_t layer_count, uint32_t batch_count )
{
	size_t bytes = 0;
	for ( uint32_t i = 0; i < layer_count; ++i )
	{
		size_t need = layers[i].weight_int8 ? plInt8HeldBlockBytes( &layers[i], batch_count ) : 0;
		bytes = need > bytes ? need : bytes;
	}
	return ( bytes + sizeof( float ) - 1 ) / sizeof( float );
}

// Where the batch's held inputs of int8 layer l go (the lanes scratch, which the int8 chain does not use otherwise),
// or NULL where the job has no batched int8 kernel or too little scratch: then each instance runs mat_vec_int8.
static uint8_t* plHeldInputs( const plMlpBatchJob* job, const plLayer* l )
{
	if ( !l->weight_int8 || job->mat_mat_int8 == NULL || l->weight_sums == NULL || job->lanes == NULL ||
		 ( (uintptr_t)job->lanes & 63u ) != 0 ||
		 plInt8HeldBlockBytes( l, job->batch_count ) > job->lanes_floats * sizeof( float ) )
	{
		return NULL;
	}
	return (uint8_t*)job->lanes;
}

plResult plMlpBatchJob_Run( const plMlpBatchJob* job )
{
	if ( !plMlpBatchJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( plUseLanes( job ) )
	{
		plRunLanes( job );
		return PLEAT_RESULT_OK;
	}
	uint32_t n = job->batch_count, widest = plWidestHidden( job->layers, job->layer_count );
	const float* x[PLEAT_BATCH_MAX];
	float* y[PLEAT_BATCH_MAX];
	for ( uint32_t b = 0; b < n; ++b )
	{
		x[b] = (const float*)job->inputs[b].ptr;
	}
	for ( uint32_t i = 0; i < job->layer_count; ++i )
	{
		const plLayer* layer = &job->layers[i];
		int last = i + 1 == job->layer_count;
		for ( uint32_t b = 0; b < n; ++b )
		{
			// The single job's ping-pong in each instance's own scratch: layer i writes ping on even i, pong on odd.
			float* ping = (float*)job->scratch[b].ptr;
			y[b] = last ? (float*)job->outputs[b].ptr : ( ( i & 1u ) ? ping + widest : ping );
		}
		plMatMatTask task = {
			.kernels = job->kernels, .layer = layer, .out = y, .x = x, .batch_count = n, .mat_vec_int8 = job->mat_vec_int8 };
		uint8_t* held = plHeldInputs( job, layer );
		if ( held != NULL )
		{
			// the batch's inputs quantised once for the layer, not once per row task
			job->quantise_int8( held, x, n, layer );
			task.mat_mat_int8 = job->mat_mat_int8;
			task.held = held;
		}
		plRunTask( job->runner, plMatMatTaskRun, layer->out_count, 64, &task );
		for ( uint32_t b = 0; b < n; ++b )
		{
			if ( !last )
			{
				plApplyActivation( y[b], layer->out_count, job->activation );
			}
			x[b] = y[b];
		}
	}
	return PLEAT_RESULT_OK;
}
