// The host allocator wrapper: every SDK allocation goes through plAlloc/plFree (allocator.h).
#include "allocator.h"

#include <string.h>

void* plAlloc( const plAllocator* allocator, size_t size, size_t align )
{
	if ( allocator == NULL || size == 0 || align == 0 || ( align & ( align - 1 ) ) != 0 )
	{
		return NULL;
	}
	if ( align < 16 )
	{
		align = 16;
	}
	return allocator->alloc( size, align, allocator->user );
}

void* plAllocZeroed( const plAllocator* allocator, size_t size, size_t align )
{
	void* p = plAlloc( allocator, size, align );
	if ( p != NULL )
	{
		memset( p, 0, size );
	}
	return p;
}

void plFree( const plAllocator* allocator, void* ptr, size_t size )
{
	if ( allocator != NULL && ptr != NULL )
	{
		allocator->free( ptr, size, allocator->user );
	}
}
