// The int8 layer of the MLP job (asset flag PLEAT_FLAG_INT8, docs/asset-format.md "int8 networks"): the input
// quantised with the layer's calibrated scale within its bounds (plInt8Input), an int32 sum of the products per row
// (plus the row's offset where the input is held shifted), the sum dequantised with the row's weight scale and the
// input scale, then the bias. plMatVecInt8_Scalar is the specification; its SIMD twins (mlp_int8_avx2.c,
// mlp_int8_avx512.c) change only how the integer sum is formed, so they give its bits exactly.
#include "jobs.h"

void plMatVecInt8_Scalar( float* out, const float* x, const plLayer* layer, const int8_t* weight, uint32_t stride,
						  uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end )
{
	int16_t q[PLEAT_MAX_INT8_COLUMNS];
	uint32_t columns = col_end - col_begin;
	for ( uint32_t c = 0; c < columns; ++c )
	{
		q[c] = (int16_t)plQuantiseInput( x[col_begin + c], layer->input_inv_scale, layer->int8_input );
	}
	for ( uint32_t r = row_begin; r < row_end; ++r )
	{
		const int8_t* w = weight + (size_t)r * stride + col_begin;
		int32_t acc = plInt8RowOffset( layer, r );
		for ( uint32_t c = 0; c < columns; ++c )
		{
			acc += (int32_t)w[c] * (int32_t)q[c];
		}
		out[r] = plDequantise( acc, layer->weight_scale[r], layer->input_scale[0], layer->bias[r] );
	}
}

// The scalar set's layout of a batch's held inputs: instance b's values (plQuantiseInput's, int16 for a FIRST input,
// else int8) from b · plScalarHeldStride bytes on.
static size_t plScalarHeldStride( const plLayer* layer )
{
	return ( (size_t)layer->in_count * plInt8HeldBytes( layer ) + 63u ) & ~(size_t)63u;
}

void plQuantiseInt8_Scalar( void* held, const float* const* x, uint32_t batch_count, const plLayer* layer )
{
	for ( uint32_t b = 0; b < batch_count; ++b )
	{
		uint8_t* mine = (uint8_t*)held + b * plScalarHeldStride( layer );
		for ( uint32_t c = 0; c < layer->in_count; ++c )
		{
			int32_t q = plQuantiseInput( x[b][c], layer->input_inv_scale, layer->int8_input );
			if ( layer->int8_input == PLEAT_INT8_INPUT_FIRST )
			{
				( (int16_t*)mine )[c] = (int16_t)q;
			}
			else
			{
				( (int8_t*)mine )[c] = (int8_t)q;
			}
		}
	}
}

// The batched form's specification: plMatVecInt8_Scalar's sums per instance from the held inputs.
void plMatMatInt8_Scalar( float* const* out, const void* held, uint32_t batch_count, const plLayer* layer,
						  const int8_t* weight, uint32_t stride, uint32_t col_begin, uint32_t columns,
						  uint32_t row_begin, uint32_t row_end )
{
	int wide = layer->int8_input == PLEAT_INT8_INPUT_FIRST;
	for ( uint32_t r = row_begin; r < row_end; ++r )
	{
		const int8_t* w = weight + (size_t)r * stride;
		for ( uint32_t b = 0; b < batch_count; ++b )
		{
			const uint8_t* mine = (const uint8_t*)held + b * plScalarHeldStride( layer );
			int32_t acc = plInt8RowOffset( layer, r );
			for ( uint32_t c = 0; c < columns; ++c )
			{
				int32_t q = wide ? ( (const int16_t*)mine )[col_begin + c] : ( (const int8_t*)mine )[col_begin + c];
				acc += (int32_t)w[c] * q;
			}
			out[b][r] = plDequantise( acc, layer->weight_scale[r], layer->input_scale[0], layer->bias[r] );
		}
	}
}
