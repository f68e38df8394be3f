// Running a task through the host's task system (pleat.h, THREADING): the SDK never starts a thread of its own.
#include "tasks.h"

#include <stddef.h>

int plTaskRunner_IsParallel( const plTaskRunner* runner )
{
	return runner != NULL && runner->enqueue_task != NULL && runner->worker_count > 1;
}

void plRunTask( const plTaskRunner* runner, plTaskFn* task, uint32_t item_count, uint32_t min_range, void* context )
{
	if ( item_count == 0 )
	{
		return;
	}
	if ( !plTaskRunner_IsParallel( runner ) )
	{
		task( 0, item_count, 0, context );
		return;
	}
	// enqueue_task may run the task inline and return NULL: then it is already done.
	void* handle = runner->enqueue_task( task, item_count, min_range == 0 ? 1 : min_range, context,
										 runner->task_context );
	if ( handle != NULL )
	{
		runner->finish_task( handle, runner->task_context );
	}
}
