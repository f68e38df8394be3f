// The int8 layer of the MLP job (asset flag PLEAT_FLAG_INT8, docs/asset-format.md "int8 networks"): the input
// quantised with the layer's calibrated scale, an int32 sum of int8 products per row, the sum dequantised with the
// row's weight scale and the input scale, then the bias. plMatVecInt8_Scalar is the specification; its SIMD twins
// (mlp_int8_avx2.c, mlp_int8_avx512.c) change only how the integer sum is formed, so they give its bits exactly.
#include "jobs.h"

void plMatVecInt8_Scalar( float* out, const float* x, const int8_t* weight, const float* weight_scale,
						  float input_scale, float input_inv_scale, const float* bias, uint32_t in_count,
						  uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end )
{
	int8_t q[PLEAT_MAX_INT8_COLUMNS];
	uint32_t columns = col_end - col_begin;
	for ( uint32_t c = 0; c < columns; ++c )
	{
		q[c] = plQuantise( x[col_begin + c], input_inv_scale );
	}
	for ( uint32_t r = row_begin; r < row_end; ++r )
	{
		const int8_t* w = weight + (size_t)r * in_count + col_begin;
		int32_t acc = 0;
		for ( uint32_t c = 0; c < columns; ++c )
		{
			acc += (int32_t)w[c] * (int32_t)q[c];
		}
		out[r] = plDequantise( acc, weight_scale[r], input_scale, bias[r] );
	}
}
