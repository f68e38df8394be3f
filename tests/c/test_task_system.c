#define _POSIX_C_SOURCE 200809L
#include "test_task_system.h"

#include <pthread.h>
#include <stdlib.h>

#define PLEAT_TEST_MAX_WORKERS 8

typedef struct plTestRange
{
	plTaskFn* task;
	void* context;
	uint32_t begin, end, worker;
	pthread_t thread;
	int started;
} plTestRange;

struct plTestTaskSystem
{
	uint32_t worker_count;
	uint32_t parallel_tasks;
	plTestRange ranges[PLEAT_TEST_MAX_WORKERS];
	int busy;
};

static void* plTestRangeMain( void* arg )
{
	plTestRange* r = (plTestRange*)arg;
	r->task( r->begin, r->end, r->worker, r->context );
	return NULL;
}

static void* plTestEnqueue( plTaskFn* task, uint32_t item_count, uint32_t min_range, void* task_context,
							void* user_context )
{
	plTestTaskSystem* s = (plTestTaskSystem*)user_context;
	uint32_t workers = s->worker_count;
	if ( min_range == 0 )
	{
		min_range = 1;
	}
	while ( workers > 1 && item_count / workers < min_range )
	{
		workers--;
	}
	if ( workers <= 1 || s->busy )
	{
		task( 0, item_count, 0, task_context );
		return NULL;
	}
	s->busy = 1;
	s->parallel_tasks++;
	uint32_t per = item_count / workers, extra = item_count % workers, begin = 0;
	for ( uint32_t w = 0; w < workers; ++w )
	{
		plTestRange* r = &s->ranges[w];
		r->task = task;
		r->context = task_context;
		r->begin = begin;
		r->end = begin + per + ( w < extra ? 1 : 0 );
		r->worker = w;
		r->started = 0;
		begin = r->end;
	}
	for ( uint32_t w = 1; w < workers; ++w )
	{
		plTestRange* r = &s->ranges[w];
		if ( pthread_create( &r->thread, NULL, plTestRangeMain, r ) == 0 )
		{
			r->started = 1;
		}
		else
		{
			r->task( r->begin, r->end, r->worker, r->context );
		}
	}
	plTestRangeMain( &s->ranges[0] );
	for ( uint32_t w = workers; w < PLEAT_TEST_MAX_WORKERS; ++w )
	{
		s->ranges[w].started = 0;
	}
	return s;
}

static void plTestFinish( void* user_task, void* user_context )
{
	plTestTaskSystem* s = (plTestTaskSystem*)user_context;
	(void)user_task;
	for ( uint32_t w = 1; w < PLEAT_TEST_MAX_WORKERS; ++w )
	{
		if ( s->ranges[w].started )
		{
			pthread_join( s->ranges[w].thread, NULL );
			s->ranges[w].started = 0;
		}
	}
	s->busy = 0;
}

plTestTaskSystem* plTestTaskSystem_Create( uint32_t worker_count )
{
	plTestTaskSystem* s = (plTestTaskSystem*)calloc( 1, sizeof( plTestTaskSystem ) );
	if ( s != NULL )
	{
		s->worker_count = worker_count < 1 ? 1 : ( worker_count > PLEAT_TEST_MAX_WORKERS ? PLEAT_TEST_MAX_WORKERS : worker_count );
	}
	return s;
}

void plTestTaskSystem_Destroy( plTestTaskSystem* s )
{
	free( s );
}

void plTestTaskSystem_Install( plTestTaskSystem* s, plContextDef* def )
{
	def->enqueue_task = plTestEnqueue;
	def->finish_task = plTestFinish;
	def->task_context = s;
	def->worker_count = s->worker_count;
}

uint32_t plTestTaskSystem_ParallelTaskCount( const plTestTaskSystem* s )
{
	return s->parallel_tasks;
}
