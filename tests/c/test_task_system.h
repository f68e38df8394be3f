// Test helper: a simple task system for plContextDef's enqueue/finish hooks. Each enqueued task is cut into
// worker_count ranges; ranges 1.. run on fresh pthreads, range 0 on the caller; finish joins them.
#ifndef PLEAT_TEST_TASK_SYSTEM_H
#define PLEAT_TEST_TASK_SYSTEM_H
#include "pleat/pleat.h"

typedef struct plTestTaskSystem plTestTaskSystem;

plTestTaskSystem* plTestTaskSystem_Create( uint32_t worker_count );
void plTestTaskSystem_Destroy( plTestTaskSystem* system );
// Fills the task fields of a context def (enqueue_task, finish_task, task_context, worker_count).
void plTestTaskSystem_Install( plTestTaskSystem* system, plContextDef* def );
// Number of tasks that were split over more than one worker so far.
uint32_t plTestTaskSystem_ParallelTaskCount( const plTestTaskSystem* system );

#endif
