// Internal: the context, its object tables, logging, the CPU kernel table and the workers' scratch pool. The context
// knows nothing of assets or instances: each table is told by its first insert how to destroy what it holds
// (plDestroyObjectFn), so plDestroyContext cleans up without calling into asset.c or instance.c; the scratch pool is
// sized by whoever creates objects (plReserveBatchScratch) and claimed by whoever steps them (plClaimBatchScratch).
#ifndef PLEAT_CORE_H
#define PLEAT_CORE_H
#include "allocator.h"
#include "kernels/kernels.h"
#include "pleat/pleat.h"
#include "tasks.h"

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#define PLEAT_MAX_CONTEXTS 64
#define PLEAT_DEF_COOKIE 0x504c4154 // "PLAT"

// Slot generations (pleat.h, HANDLES): a slot holds the generation of its live object, or of the last one it held
// (0 = never used); a new object gets the next one, and a slot whose generation is PLEAT_GENERATION_LAST is retired
// instead of wrapping to 0, so no handle is ever issued twice.
#define PLEAT_GENERATION_LAST UINT32_MAX

typedef struct plSlot
{
	void* object;        // NULL = free (or retired)
	uint32_t generation; // of the live object, or of the last one; 0 = never used
} plSlot;

typedef struct plContextData plContextData;

// Scratch blocks a context keeps for plStepInstances's lanes forms (one per worker, at most this many).
#define PLEAT_BATCH_SCRATCH_SLOTS 8

// Frees an object a slot table holds (its owner's destroy, without the slot bookkeeping).
typedef void plDestroyObjectFn( plContextData* ctx, void* object );

typedef struct plSlotTable
{
	plSlot* slots;
	uint32_t capacity;
	uint32_t live_count;
	plDestroyObjectFn* destroy; // set by the first insert; what plDestroyContext calls for objects still alive
} plSlotTable;

struct plContextData
{
	plAllocator allocator; // counting wrapper around the host hooks; pass &ctx->allocator everywhere
	plAllocFn* host_alloc;
	plFreeFn* host_free;
	void* host_allocator_context;
	_Atomic uint64_t live_bytes;

	plTaskRunner runner; // the def's task hooks; worker_count 1 without them

	plLogFn* log;
	void* log_context;

	plKernels kernels; // chosen once at creation (plChooseKernels): the single-instance kernels and their batched twins

	// The workers' scratch pool (plStepInstances's transposed networks, batched normals and contact): one block per
	// worker up to PLEAT_BATCH_SCRATCH_SLOTS, claimed per use, grown at instance creation to the largest asset's need so far
	// (plReserveBatchScratch). Context bookkeeping: through the host hooks, not counted in live_bytes, freed with the
	// context.
	float* batch_scratch[PLEAT_BATCH_SCRATCH_SLOTS];
	size_t batch_scratch_floats; // of every block
	uint32_t batch_scratch_slots;
	atomic_int batch_scratch_busy[PLEAT_BATCH_SCRATCH_SLOTS];

	plSlotTable assets;
	plSlotTable instances;
	plSlotTable scenes; // scenes own instances of their characters (scene.c)
	plContext handle; // this context's own handle, written into the handles of its assets and instances
};

// The process-wide context table (context.c). Internal: exposed so that a test can start a slot near its last
// generation and see it retire without 2^32 create/destroy cycles.
typedef struct plContextTable
{
	plContextData* contexts[PLEAT_MAX_CONTEXTS];
	uint32_t generations[PLEAT_MAX_CONTEXTS]; // as plSlot.generation
} plContextTable;
extern plContextTable g_plContextTable;

// The scratch pool: grow every block to at least `floats` floats (at instance creation; on failure the pool is left
// empty, and a batch that finds no block big enough runs the stages that need one with scratch-free kernels, with
// the same results). Claim returns the index of a free block of at least `floats` floats, or -1; release gives it
// back. Any thread may claim (concurrent plStepInstances calls on different instances).
void plReserveBatchScratch( plContextData* ctx, size_t floats );
int plClaimBatchScratch( plContextData* ctx, size_t floats );
// A crowd of GPU-backend instances (PLEAT_MLP_BACKEND_GPU) steps as groups of up to PLEAT_GPU_GROUP_MAX instances of one
// asset, one set of dispatches each (step/batch.c): their entries and GL batch members live in one scratch block of
// PLEAT_GPU_GROUP_FLOATS floats (256 bytes an instance; batch.c checks the carve fits), reserved when such an
// instance is created. A call that finds no block free forms groups of PLEAT_BATCH_MAX.
#define PLEAT_GPU_GROUP_MAX 1024u
#define PLEAT_GPU_GROUP_FLOATS ( (size_t)PLEAT_GPU_GROUP_MAX * 64u )
void plReleaseBatchScratch( plContextData* ctx, int slot );

// The live context a handle names (index and generation both match), or NULL. Asset and instance lookups go through
// this with the context handle they carry.
plContextData* plGetContext( plContext context );

// The start of every create and load (plLoadAsset, plCreateInstance, plCreateScene): the handle out parameter is
// cleared (when there is one), then INVALID_ARGUMENT without a def or an out parameter, INVALID_HANDLE for a context
// that is not alive; on OK *out_ctx is the context.
plResult plBeginCreate( plContext context, const void* def, void* out_handle, size_t handle_size,
						 plContextData** out_ctx );

// The first checks of an entry point on an object: its looked-up data (NULL for a dead handle) and whether its other
// arguments are usable. Which code wins when both are wrong is part of each function's contract, so the name says the
// order: the getters that clear their outputs check the arguments first, the setters the handle first.
static inline plResult plCheckArgumentsThenHandle( int arguments_valid, const void* object )
{
	return !arguments_valid ? PLEAT_RESULT_INVALID_ARGUMENT
							: ( object == NULL ? PLEAT_RESULT_INVALID_HANDLE : PLEAT_RESULT_OK );
}

static inline plResult plCheckHandleThenArguments( const void* object, int arguments_valid )
{
	return object == NULL ? PLEAT_RESULT_INVALID_HANDLE
						  : ( !arguments_valid ? PLEAT_RESULT_INVALID_ARGUMENT : PLEAT_RESULT_OK );
}

void plLog( const plContextData* ctx, plLogLevel level, plLogItem item, const char* format, ... )
#if defined( __GNUC__ )
	__attribute__( ( format( printf, 4, 5 ) ) )
#endif
	;

// Slot tables: insert puts object in a free slot (growing the table; OUT_OF_MEMORY when it cannot, at capacity or out of
// memory) and writes the index1 and generation of its handle; destroy is how the table's objects are freed (the same
// for every insert). Get is the live object a handle's index1 and generation name, or NULL.
plResult plSlotTable_Insert( plContextData* ctx, plSlotTable* table, void* object, plDestroyObjectFn* destroy,
							 uint32_t* out_index1, uint32_t* out_generation );
void* plSlotTable_Get( const plSlotTable* table, uint32_t index1, uint32_t generation );
// Destroys the object a handle names (through the table's destroy callback) and frees its slot; INVALID_HANDLE when
// the handle names none.
plResult plSlotTable_Destroy( plContextData* ctx, plSlotTable* table, uint32_t index1, uint32_t generation );
// Destroys every object still in the table (through its destroy callback), then frees the table itself.
void plSlotTable_Free( plContextData* ctx, plSlotTable* table );

#endif
