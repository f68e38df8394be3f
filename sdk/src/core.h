// Internal: the context, its object tables, logging and the CPU kernel dispatch table.
#ifndef PLEAT_CORE_H
#define PLEAT_CORE_H
#include "allocator.h"
#include "kernels.h"
#include "pleat/pleat.h"

#include <stdatomic.h>
#include <stdint.h>

#define PLEAT_MAX_CONTEXTS 64
#define PLEAT_DEF_COOKIE 0x504c4154 // "PLAT"

typedef struct plSlot
{
	void* object;        // NULL = free
	uint16_t generation; // >= 1
} plSlot;

typedef struct plSlotTable
{
	plSlot* slots;
	uint32_t capacity;
	uint32_t live_count;
} plSlotTable;

typedef struct plContextData
{
	plAllocator allocator; // counting wrapper around the host hooks; pass &ctx->allocator everywhere
	plAllocFn* host_alloc;
	plFreeFn* host_free;
	void* host_allocator_context;
	_Atomic uint64_t live_bytes;

	plEnqueueTaskFn* enqueue_task;
	plFinishTaskFn* finish_task;
	void* task_context;
	uint32_t worker_count;

	plLogFn* log;
	void* log_context;

	plKernels kernels;
	int uses_avx2;

	plSlotTable assets;
	plSlotTable instances;
	uint16_t index1;
} plContextData;

// The task system a job may split its work with (NULL members = serial).
typedef struct plTaskRunner
{
	plEnqueueTaskFn* enqueue_task;
	plFinishTaskFn* finish_task;
	void* task_context;
	uint32_t worker_count;
} plTaskRunner;

// Runs task over [0, item_count) through the runner (or inline) and waits for it.
void plRunTask( const plTaskRunner* runner, plTaskFn* task, uint32_t item_count, uint32_t min_range, void* context );

plContextData* plGetContext( plContext context );
plContextData* plGetContextByIndex1( uint16_t index1 );
void plLog( const plContextData* ctx, plLogLevel level, plLogItem item, const char* format, ... )
#if defined( __GNUC__ )
	__attribute__( ( format( printf, 4, 5 ) ) )
#endif
	;

// Slot tables: insert returns the slot index or UINT32_MAX (out of memory / capacity).
uint32_t plSlotTable_Insert( plContextData* ctx, plSlotTable* table, void* object );
void* plSlotTable_Get( const plSlotTable* table, uint32_t index1, uint16_t generation );
void plSlotTable_Remove( plSlotTable* table, uint32_t index1 );
void plSlotTable_Free( plContextData* ctx, plSlotTable* table );

// Asset and instance internals used by context.c to clean up.
void plAssetData_Destroy( plContextData* ctx, void* asset );
void plInstanceData_Destroy( plContextData* ctx, void* instance );

#endif
