// Internal: the host's task system as the jobs see it. The context keeps one plTaskRunner built from its def; a job
// that can split its work takes a pointer to it (NULL = serial) and never knows about contexts, assets or instances.
#ifndef PLEAT_TASKS_H
#define PLEAT_TASKS_H
#include "pleat/pleat.h"

#include <stdint.h>

// The task system a job may split its work with (NULL enqueue_task or worker_count <= 1 = serial on the caller).
typedef struct plTaskRunner
{
	plEnqueueTaskFn* enqueue_task;
	plFinishTaskFn* finish_task;
	void* task_context;
	uint32_t worker_count;
} plTaskRunner;

// Runs task over [0, item_count) through the runner (or inline) and waits for it.
void plRunTask( const plTaskRunner* runner, plTaskFn* task, uint32_t item_count, uint32_t min_range, void* context );

// Non-zero when the runner splits work over more than one worker (so work that cannot be split runs better inline).
int plTaskRunner_IsParallel( const plTaskRunner* runner );

#endif
