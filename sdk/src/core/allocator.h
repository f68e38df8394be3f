// Internal: the host allocator every part of the SDK allocates through (see plContextDef in pleat.h).
// Owned by the SDK core (allocator.c). Nothing in sdk/src calls malloc/free directly.
#ifndef PLEAT_ALLOCATOR_H
#define PLEAT_ALLOCATOR_H
#include <stddef.h>

typedef struct plAllocator
{
	void* ( *alloc )( size_t size, size_t align, void* user );
	void ( *free )( void* ptr, size_t size, void* user );
	void* user;
} plAllocator;

// Returns NULL on failure or size == 0; align is a power of two (at least 16 is always honoured).
void* plAlloc( const plAllocator* allocator, size_t size, size_t align );
void* plAllocZeroed( const plAllocator* allocator, size_t size, size_t align );
// ptr may be NULL; size must be the size passed to plAlloc.
void plFree( const plAllocator* allocator, void* ptr, size_t size );

// v rounded up to a whole number of 64-byte lines: the parts carved out of one 64-byte-aligned plAlloc block (an
// instance's buffers, a scene's, an asset's derived tables) each start on a line of their own.
static inline size_t plAlign64( size_t v )
{
	return ( v + 63u ) & ~(size_t)63u;
}

#endif
