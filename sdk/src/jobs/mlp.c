// The MLP job (latent predictor f_LP and decoder f_dec): y = W x + b per Linear layer, activation on hidden layers,
// the last layer linear. plMatVec_Scalar is the specification of the mat-vec; mlp_avx2.c is its fast twin.
#include "jobs.h"

#include <math.h>

void plMatVec_Scalar( float* out, const float* x, const void* weight, int weight_fp16, const float* bias,
					  uint32_t in_count, uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end )
{
	for ( uint32_t r = row_begin; r < row_end; ++r )
	{
		out[r] = plDotRowScalar( x + col_begin, weight, weight_fp16, (size_t)r * in_count + col_begin,
								 col_end - col_begin ) +
				 bias[r];
	}
}

static float plActivate( float v, uint32_t activation )
{
	if ( activation == PLEAT_ACTIVATION_RELU )
	{
		return v > 0.0f ? v : 0.0f;
	}
	// SiLU: v · sigmoid(v)
	return v / ( 1.0f + expf( -v ) );
}

void plApplyActivation( float* y, uint32_t count, uint32_t activation )
{
	for ( uint32_t r = 0; r < count; ++r )
	{
		y[r] = plActivate( y[r], activation );
	}
}

typedef struct plMatVecTask
{
	const plKernels* kernels;
	float* out;
	const float* x;
	const plLayer* layer;
} plMatVecTask;

// Rows [begin, end) block by block, each over its own column window.
static void plMatVecTaskRun( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	const plMatVecTask* t = (const plMatVecTask*)context;
	const plLayer* l = t->layer;
	plLayerBlock blocks[PLEAT_MAX_LAYER_BLOCKS];
	uint32_t block_count = plLayerBlocks( l, blocks );
	for ( uint32_t i = 0; i < block_count; ++i )
	{
		uint32_t rb, re;
		if ( !plBlockRowsWithin( &blocks[i], begin, end, &rb, &re ) )
		{
			continue;
		}
		if ( l->weight_int8 )
		{
			// packed or in place alike: the window of x and each row's weights over it (mlp_int8.c)
			const int8_t* w = (const int8_t*)( l->packed != NULL ? l->packed : l->weight );
			uint32_t stride = l->packed != NULL ? l->packed_width : l->in_count;
			uint32_t cb = l->packed != NULL ? 0 : blocks[i].col_begin;
			uint32_t ce = l->packed != NULL ? l->packed_width : blocks[i].col_end;
			const float* x = l->packed != NULL ? t->x + blocks[i].col_begin : t->x;
			t->kernels->mat_vec_int8( t->out, x, l, w, stride, cb, ce, rb, re );
		}
		else if ( l->packed != NULL )
		{
			// the packed copy: the block's input window, each row's weights contiguous (kernels.h plLayer)
			t->kernels->mat_vec( t->out, t->x + blocks[i].col_begin, l->packed, l->weight_fp16, l->bias,
								 l->packed_width, 0, l->packed_width, rb, re );
		}
		else
		{
			t->kernels->mat_vec( t->out, t->x, l->weight, l->weight_fp16, l->bias, l->in_count, blocks[i].col_begin,
								 blocks[i].col_end, rb, re );
		}
	}
}

int plMlpJob_Validate( const plMlpJob* job )
{
	if ( job == NULL || job->layers == NULL || job->layer_count == 0 || job->layer_count > PLEAT_MAX_LAYERS ||
		 job->kernels == NULL || job->kernels->mat_vec == NULL || job->kernels->mat_vec_int8 == NULL ||
		 ( job->activation != PLEAT_ACTIVATION_RELU && job->activation != PLEAT_ACTIVATION_SILU ) )
	{
		return 0;
	}
	uint32_t widest = 0;
	for ( uint32_t i = 0; i < job->layer_count; ++i )
	{
		const plLayer* l = &job->layers[i];
		if ( l->weight == NULL || l->bias == NULL || l->in_count == 0 || l->out_count == 0 ||
			 ( i > 0 && l->in_count != job->layers[i - 1].out_count ) || !plInt8LayerIsValid( l ) )
		{
			return 0;
		}
		if ( i + 1 < job->layer_count && l->out_count > widest )
		{
			widest = l->out_count;
		}
	}
	const plLayer* last = &job->layers[job->layer_count - 1];
	return PLEAT_SPAN_HOLDS( job->input, 4, job->layers[0].in_count ) && job->input.stride_bytes == 4 &&
		   PLEAT_SPAN_HOLDS( job->output, 4, last->out_count ) && job->output.stride_bytes == 4 &&
		   ( widest == 0 || ( PLEAT_SPAN_HOLDS( job->scratch, 4, 2 * widest ) && job->scratch.stride_bytes == 4 ) );
}

plResult plMlpJob_Run( const plMlpJob* job )
{
	if ( !plMlpJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	uint32_t widest = 0;
	for ( uint32_t i = 0; i + 1 < job->layer_count; ++i )
	{
		widest = job->layers[i].out_count > widest ? job->layers[i].out_count : widest;
	}
	float* ping = (float*)job->scratch.ptr;
	float* pong = ping + widest;
	const float* x = (const float*)job->input.ptr;
	for ( uint32_t i = 0; i < job->layer_count; ++i )
	{
		const plLayer* layer = &job->layers[i];
		int last = i + 1 == job->layer_count;
		float* y = last ? (float*)job->output.ptr : ( ( i & 1u ) ? pong : ping );
		plMatVecTask task = { job->kernels, y, x, layer };
		plRunTask( job->runner, plMatVecTaskRun, layer->out_count, 64, &task );
		if ( !last )
		{
			plApplyActivation( y, layer->out_count, job->activation );
		}
		x = y;
	}
	return PLEAT_RESULT_OK;
}
