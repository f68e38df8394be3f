// The context: host hooks (allocator, task system, log), the process-wide context table and the per-context object
// tables that give assets and instances their index + generation handles.
#if defined( __linux__ ) && !defined( _DEFAULT_SOURCE )
#define _DEFAULT_SOURCE // madvise (the default allocator's huge pages)
#endif
#include "core.h"
#include "kernels/kernels_batch.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#if defined( __linux__ )
#include <sys/mman.h>
#endif

plContextTable g_plContextTable;

typedef struct plResultInfo
{
	plResult result;
	const char* name;        // "PLEAT_RESULT_" + the name in PLEAT_RESULTS
	const char* description; // the description there
} plResultInfo;

// The entry of PLEAT_RESULTS for result, or NULL for a value not listed.
static const plResultInfo* plFindResult( plResult result )
{
	static const plResultInfo table[] = {
#define PLEAT_RESULT_INFO_( name, value, description ) { PLEAT_RESULT_##name, "PLEAT_RESULT_" #name, description },
		PLEAT_RESULTS( PLEAT_RESULT_INFO_ )
#undef PLEAT_RESULT_INFO_
	};
	for ( size_t i = 0; i < sizeof( table ) / sizeof( table[0] ); ++i )
	{
		if ( table[i].result == result )
		{
			return &table[i];
		}
	}
	return NULL;
}

const char* plResultString( plResult result )
{
	const plResultInfo* info = plFindResult( result );
	return info != NULL ? info->name : "PLEAT_RESULT_UNKNOWN";
}

const char* plResultDescription( plResult result )
{
	const plResultInfo* info = plFindResult( result );
	return info != NULL ? info->description : "unknown result";
}

plVersion plGetVersion( void )
{
	plVersion version = { PLEAT_VERSION_MAJOR, PLEAT_VERSION_MINOR, PLEAT_VERSION_PATCH, PLEAT_ASSET_VERSION_MAJOR };
	return version;
}

const char* plLogItemString( plLogItem item )
{
	switch ( item )
	{
#define PLEAT_LOG_CASE_( name, id, message )                                                                           \
	case PLEAT_LOG_##name:                                                                                             \
		return message;
		PLEAT_LOG_ITEMS( PLEAT_LOG_CASE_ )
#undef PLEAT_LOG_CASE_
	}
	return "unknown item";
}

void plLog( const plContextData* ctx, plLogLevel level, plLogItem item, const char* format, ... )
{
	if ( ctx == NULL || ctx->log == NULL )
	{
		return;
	}
	char message[512];
	int n = snprintf( message, sizeof( message ), "%s", plLogItemString( item ) );
	if ( format != NULL && n > 0 && (size_t)n < sizeof( message ) - 2 )
	{
		message[n++] = ':';
		message[n++] = ' ';
		va_list args;
		va_start( args, format );
		vsnprintf( message + n, sizeof( message ) - (size_t)n, format, args );
		va_end( args );
	}
	ctx->log( level, item, message, ctx->log_context );
}

// Default allocator: C11 aligned_alloc (size rounded up to the alignment as C11 requires). Blocks of 2 MiB and more —
// in practice assets, whose network weights and blend shapes every step streams in full — are 2 MiB aligned and, on
// Linux, advised for transparent huge pages: the 12 MB reference asset then spans ~6 TLB entries instead of ~3,000
// (−15–20 % per fp32 step measured, docs/benchmarks.md). Costs up to 2 MiB of rounding per such block. A host
// allocator makes this choice for itself (pleat.h, MEMORY).
#define PLEAT_HUGE_PAGE_BYTES ( (size_t)2 << 20 )
static void* plDefaultAlloc( size_t size, size_t align, void* user )
{
	(void)user;
	if ( size >= PLEAT_HUGE_PAGE_BYTES && align < PLEAT_HUGE_PAGE_BYTES )
	{
		align = PLEAT_HUGE_PAGE_BYTES;
	}
	size_t rounded = ( size + align - 1 ) & ~( align - 1 );
	if ( rounded < size )
	{
		return NULL;
	}
	void* p = aligned_alloc( align, rounded );
#if defined( __linux__ ) && defined( MADV_HUGEPAGE )
	if ( p != NULL && align == PLEAT_HUGE_PAGE_BYTES )
	{
		(void)madvise( p, rounded, MADV_HUGEPAGE ); // advice only: without THP the block simply stays in 4 KiB pages
	}
#endif
	return p;
}

static void plDefaultFree( void* ptr, size_t size, void* user )
{
	(void)size;
	(void)user;
	free( ptr );
}

static void* plCountingAlloc( size_t size, size_t align, void* user )
{
	plContextData* ctx = (plContextData*)user;
	void* p = ctx->host_alloc( size, align, ctx->host_allocator_context );
	if ( p != NULL )
	{
		atomic_fetch_add( &ctx->live_bytes, (uint64_t)size );
	}
	return p;
}

static void plCountingFree( void* ptr, size_t size, void* user )
{
	plContextData* ctx = (plContextData*)user;
	atomic_fetch_sub( &ctx->live_bytes, (uint64_t)size );
	ctx->host_free( ptr, size, ctx->host_allocator_context );
}

plContextDef plDefaultContextDef( void )
{
	plContextDef def = { .worker_count = 1, .max_isa = PLEAT_KERNEL_SET_AVX512, .internal_cookie = PLEAT_DEF_COOKIE };
	return def;
}

plResult plCreateContext( const plContextDef* def, plContext* out_context )
{
	if ( out_context != NULL )
	{
		memset( out_context, 0, sizeof( *out_context ) );
	}
	if ( def == NULL || out_context == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( def->internal_cookie != PLEAT_DEF_COOKIE || ( def->alloc == NULL ) != ( def->free == NULL ) ||
		 ( def->enqueue_task == NULL ) != ( def->finish_task == NULL ) || def->worker_count > 64 ||
		 (int)def->max_isa < (int)PLEAT_KERNEL_SET_SCALAR )
	{
		return PLEAT_RESULT_INVALID_DEF;
	}
	uint32_t slot = UINT32_MAX;
	for ( uint32_t i = 0; i < PLEAT_MAX_CONTEXTS; ++i )
	{
		// A retired slot (its generation used up) stays empty for the life of the process.
		if ( g_plContextTable.contexts[i] == NULL && g_plContextTable.generations[i] != PLEAT_GENERATION_LAST )
		{
			slot = i;
			break;
		}
	}
	if ( slot == UINT32_MAX )
	{
		return PLEAT_RESULT_CAPACITY_EXCEEDED;
	}
	plAllocFn* host_alloc = def->alloc != NULL ? def->alloc : plDefaultAlloc;
	plFreeFn* host_free = def->free != NULL ? def->free : plDefaultFree;
	plContextData* ctx = (plContextData*)host_alloc( sizeof( plContextData ), 64, def->allocator_context );
	if ( ctx == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	memset( ctx, 0, sizeof( *ctx ) );
	ctx->host_alloc = host_alloc;
	ctx->host_free = host_free;
	ctx->host_allocator_context = def->allocator_context;
	atomic_init( &ctx->live_bytes, 0 );
	ctx->allocator.alloc = plCountingAlloc;
	ctx->allocator.free = plCountingFree;
	ctx->allocator.user = ctx;
	ctx->runner.enqueue_task = def->enqueue_task;
	ctx->runner.finish_task = def->finish_task;
	ctx->runner.task_context = def->task_context;
	ctx->runner.worker_count = def->enqueue_task != NULL ? ( def->worker_count == 0 ? 1 : def->worker_count ) : 1;
	ctx->log = def->log;
	ctx->log_context = def->log_context;
	// The one choice of kernels for the context's life: a max_isa above the widest set this library knows (a newer
	// header's) asks for the widest; the deprecated force_scalar wins over it.
	plChooseKernels( &ctx->kernels, def->force_scalar ? PLEAT_KERNEL_SET_SCALAR : def->max_isa );
	g_plContextTable.generations[slot] += 1;
	g_plContextTable.contexts[slot] = ctx;
	ctx->handle.index1 = slot + 1;
	ctx->handle.generation = g_plContextTable.generations[slot];
	*out_context = ctx->handle;
	plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_CONTEXT_CREATED, "%u workers", ctx->runner.worker_count );
	static const plLogItem kernel_items[] = { PLEAT_LOG_KERNELS_SCALAR, PLEAT_LOG_KERNELS_AVX2,
											  PLEAT_LOG_KERNELS_AVX512 };
	plLog( ctx, PLEAT_LOG_LEVEL_INFO, kernel_items[ctx->kernels.set], "%s", ctx->kernels.batch->isa );
	return PLEAT_RESULT_OK;
}

plContextData* plGetContext( plContext context )
{
	if ( context.index1 == 0 || context.index1 > PLEAT_MAX_CONTEXTS )
	{
		return NULL;
	}
	uint32_t slot = context.index1 - 1u;
	if ( g_plContextTable.contexts[slot] == NULL || g_plContextTable.generations[slot] != context.generation )
	{
		return NULL;
	}
	return g_plContextTable.contexts[slot];
}

int plContext_IsValid( plContext context )
{
	return plGetContext( context ) != NULL;
}

static void plFreeBatchScratch( plContextData* ctx )
{
	for ( uint32_t i = 0; i < ctx->batch_scratch_slots; ++i )
	{
		ctx->host_free( ctx->batch_scratch[i], ctx->batch_scratch_floats * sizeof( float ), ctx->host_allocator_context );
		ctx->batch_scratch[i] = NULL;
	}
	ctx->batch_scratch_slots = 0;
	ctx->batch_scratch_floats = 0;
}

void plReserveBatchScratch( plContextData* ctx, size_t floats )
{
	if ( floats == 0 )
	{
		return;
	}
	uint32_t slots = ctx->runner.worker_count < PLEAT_BATCH_SCRATCH_SLOTS ? ctx->runner.worker_count : PLEAT_BATCH_SCRATCH_SLOTS;
	if ( floats <= ctx->batch_scratch_floats && slots <= ctx->batch_scratch_slots )
	{
		return;
	}
	floats = floats > ctx->batch_scratch_floats ? floats : ctx->batch_scratch_floats;
	plFreeBatchScratch( ctx );
	for ( uint32_t i = 0; i < slots; ++i )
	{
		ctx->batch_scratch[i] = (float*)ctx->host_alloc( floats * sizeof( float ), 64, ctx->host_allocator_context );
		if ( ctx->batch_scratch[i] == NULL )
		{
			plFreeBatchScratch( ctx );
			return;
		}
		atomic_init( &ctx->batch_scratch_busy[i], 0 );
		ctx->batch_scratch_slots = i + 1;
		ctx->batch_scratch_floats = floats;
	}
}

int plClaimBatchScratch( plContextData* ctx, size_t floats )
{
	if ( floats > ctx->batch_scratch_floats )
	{
		return -1;
	}
	for ( uint32_t i = 0; i < ctx->batch_scratch_slots; ++i )
	{
		int expected = 0;
		if ( atomic_compare_exchange_strong_explicit( &ctx->batch_scratch_busy[i], &expected, 1, memory_order_acquire,
													  memory_order_relaxed ) )
		{
			return (int)i;
		}
	}
	return -1;
}

void plReleaseBatchScratch( plContextData* ctx, int slot )
{
	atomic_store_explicit( &ctx->batch_scratch_busy[slot], 0, memory_order_release );
}

plResult plDestroyContext( plContext context )
{
	plContextData* ctx = plGetContext( context );
	if ( ctx == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( ctx->assets.live_count != 0 || ctx->instances.live_count != 0 )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_WARNING, PLEAT_LOG_CONTEXT_DESTROYED_WITH_LIVE_OBJECTS, "%u assets, %u instances",
			   ctx->assets.live_count, ctx->instances.live_count );
	}
	// Scenes first (they own instances), then instances: they hold references to assets.
	plSlotTable_Free( ctx, &ctx->scenes );
	plSlotTable_Free( ctx, &ctx->instances );
	plSlotTable_Free( ctx, &ctx->assets );
	plFreeBatchScratch( ctx );
	g_plContextTable.contexts[context.index1 - 1u] = NULL; // the generation stays: the next context gets the one after
	plFreeFn* host_free = ctx->host_free;
	void* user = ctx->host_allocator_context;
	host_free( ctx, sizeof( plContextData ), user );
	return PLEAT_RESULT_OK;
}

plResult plBeginCreate( plContext context, const void* def, void* out_handle, size_t handle_size,
						 plContextData** out_ctx )
{
	if ( out_handle != NULL )
	{
		memset( out_handle, 0, handle_size );
	}
	*out_ctx = plGetContext( context );
	return plCheckArgumentsThenHandle( def != NULL && out_handle != NULL, *out_ctx );
}

plResult plContext_GetLiveBytes( plContext context, uint64_t* out_bytes )
{
	plContextData* ctx = plGetContext( context );
	plResult r = plCheckArgumentsThenHandle( out_bytes != NULL, ctx );
	if ( r == PLEAT_RESULT_OK )
	{
		*out_bytes = atomic_load( &ctx->live_bytes );
	}
	return r;
}

plResult plContext_GetKernelSet( plContext context, plKernelSet* out_kernel_set )
{
	plContextData* ctx = plGetContext( context );
	if ( out_kernel_set != NULL )
	{
		*out_kernel_set = ctx != NULL ? ctx->kernels.set : PLEAT_KERNEL_SET_SCALAR;
	}
	return plCheckArgumentsThenHandle( out_kernel_set != NULL, ctx );
}

plResult plContext_UsesAvx2( plContext context, int* out_avx2 )
{
	if ( out_avx2 == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plKernelSet kernel_set;
	plResult r = plContext_GetKernelSet( context, &kernel_set );
	*out_avx2 = kernel_set == PLEAT_KERNEL_SET_AVX2 || kernel_set == PLEAT_KERNEL_SET_AVX512;
	return r;
}

// The index of a slot for a new object: a free one, or the first of the slots the table grows by; UINT32_MAX when it
// cannot grow.
static uint32_t plSlotTable_FreeSlot( plContextData* ctx, plSlotTable* table )
{
	for ( uint32_t i = 0; i < table->capacity; ++i )
	{
		const plSlot* slot = &table->slots[i];
		if ( slot->object == NULL && slot->generation != PLEAT_GENERATION_LAST ) // retired slots are skipped for good
		{
			return i;
		}
	}
	uint32_t new_capacity = table->capacity == 0 ? 16 : table->capacity * 2;
	if ( new_capacity > 0x1000000u )
	{
		return UINT32_MAX;
	}
	// The table is the context's own bookkeeping, like the context block: allocated through the host hooks but not
	// counted in live_bytes, so plContext_GetLiveBytes is exactly 0 whenever no asset or instance is alive. It is
	// never shrunk, because the slot generations must outlive the objects (stale handles stay stale).
	size_t bytes = (size_t)new_capacity * sizeof( plSlot );
	plSlot* slots = (plSlot*)ctx->host_alloc( bytes, 16, ctx->host_allocator_context );
	if ( slots == NULL )
	{
		return UINT32_MAX;
	}
	memset( slots, 0, bytes ); // new slots: generation 0, never used
	if ( table->slots != NULL )
	{
		memcpy( slots, table->slots, table->capacity * sizeof( plSlot ) );
		ctx->host_free( table->slots, table->capacity * sizeof( plSlot ), ctx->host_allocator_context );
	}
	uint32_t index = table->capacity;
	table->slots = slots;
	table->capacity = new_capacity;
	return index;
}

plResult plSlotTable_Insert( plContextData* ctx, plSlotTable* table, void* object, plDestroyObjectFn* destroy,
							 uint32_t* out_index1, uint32_t* out_generation )
{
	table->destroy = destroy;
	uint32_t index = plSlotTable_FreeSlot( ctx, table );
	if ( index == UINT32_MAX )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	plSlot* slot = &table->slots[index];
	slot->object = object;
	slot->generation += 1;
	table->live_count += 1;
	*out_index1 = index + 1;
	*out_generation = slot->generation;
	return PLEAT_RESULT_OK;
}

void* plSlotTable_Get( const plSlotTable* table, uint32_t index1, uint32_t generation )
{
	if ( index1 == 0 || index1 > table->capacity )
	{
		return NULL;
	}
	const plSlot* slot = &table->slots[index1 - 1u];
	if ( slot->object == NULL || slot->generation != generation )
	{
		return NULL;
	}
	return slot->object;
}

static void plSlotTable_Remove( plSlotTable* table, uint32_t index1 )
{
	// The generation stays: handles of the removed object no longer find an object, and the next object of the slot
	// gets the next generation (or, at PLEAT_GENERATION_LAST, the slot is never used again).
	table->slots[index1 - 1u].object = NULL;
	table->live_count -= 1;
}

plResult plSlotTable_Destroy( plContextData* ctx, plSlotTable* table, uint32_t index1, uint32_t generation )
{
	void* object = plSlotTable_Get( table, index1, generation );
	if ( object == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	table->destroy( ctx, object );
	plSlotTable_Remove( table, index1 );
	return PLEAT_RESULT_OK;
}

void plSlotTable_Free( plContextData* ctx, plSlotTable* table )
{
	for ( uint32_t i = 0; i < table->capacity; ++i )
	{
		if ( table->slots[i].object != NULL )
		{
			table->destroy( ctx, table->slots[i].object );
			plSlotTable_Remove( table, i + 1 );
		}
	}
	if ( table->slots != NULL )
	{
		ctx->host_free( table->slots, table->capacity * sizeof( plSlot ), ctx->host_allocator_context );
	}
	table->slots = NULL;
	table->capacity = 0;
	table->live_count = 0;
}
