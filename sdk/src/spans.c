// Span helpers shared by the jobs.
#include "jobs.h"

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
