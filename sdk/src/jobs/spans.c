// Span helpers shared by the jobs, and the non-finite guard the step and the loader share.
#include "jobs.h"

#include <string.h>

int plSpan_Holds( const void* ptr, size_t bytes, uint32_t count, uint32_t stride_bytes, uint32_t element_bytes,
				  uint32_t required_count )
{
	if ( required_count == 0 )
	{
		return 1;
	}
	if ( ptr == NULL || ( (uintptr_t)ptr & 3u ) != 0 || count < required_count || stride_bytes < element_bytes ||
		 ( stride_bytes & 3u ) != 0 )
	{
		return 0;
	}
	uint64_t needed = (uint64_t)( required_count - 1u ) * stride_bytes + element_bytes;
	return needed <= (uint64_t)bytes;
}

plSpan plMakeSpan( void* ptr, uint32_t count, uint32_t stride_bytes )
{
	plSpan s = { ptr, (size_t)count * stride_bytes, count, stride_bytes };
	return s;
}

plConstSpan plMakeConstSpan( const void* ptr, uint32_t count, uint32_t stride_bytes )
{
	plConstSpan s = { ptr, (size_t)count * stride_bytes, count, stride_bytes };
	return s;
}

int plSpan_ElementwiseFloats( const plConstSpan* input, const plSpan* output )
{
	uint32_t n = input->count;
	return n > 0 && output->count == n && input->stride_bytes == 4 && output->stride_bytes == 4 &&
		   PLEAT_SPAN_HOLDS( *input, 4, n ) && PLEAT_SPAN_HOLDS( *output, 4, n );
}

int plAllFiniteFloats( const float* v, size_t count )
{
	// Exponent bits all ones = Inf or NaN; OR-ed over the whole array without an early exit so the loop vectorises.
	uint32_t non_finite = 0;
	for ( size_t i = 0; i < count; ++i )
	{
		uint32_t bits;
		memcpy( &bits, v + i, sizeof( bits ) );
		non_finite |= (uint32_t)( ( bits & 0x7F800000u ) == 0x7F800000u );
	}
	return non_finite == 0;
}
