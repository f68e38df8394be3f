// Helpers the benchmark programs share: the clock, medians, aligned file reads, the golden motion (case.bin) and a
// two-worker host task system for plContextDef's hooks.
#ifndef PLEAT_BENCH_SUPPORT_H
#define PLEAT_BENCH_SUPPORT_H
#include "pleat/pleat.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <time.h>

// CLOCK_MONOTONIC (wall time, the default) or CLOCK_THREAD_CPUTIME_ID (this thread's CPU time).
extern clockid_t g_benchClock;
double BenchNowUs( void );
// Sorts values in place; the median (0 for count 0).
double BenchMedian( double* values, size_t count );
// The 1-minute load average (/proc/loadavg), -1 where there is none.
double BenchLoadAverage( void );
// The whole file in a 64-byte aligned block (free with free()), NULL on failure.
uint8_t* BenchReadFile( const char* path, size_t* out_size );
// Where a program writes its JSON: path, or stdout when path is NULL; NULL, with a message naming the program on
// stderr, when the file cannot be opened. BenchCloseOutput closes it (never stdout).
FILE* BenchOpenOutput( const char* program, const char* path );
void BenchCloseOutput( FILE* f );

// The poses of a case.bin (tools/pleat/reference/golden.py writes it; the expected outputs are not read).
typedef struct BenchMotion
{
	uint32_t frame_count;
	uint32_t joint_count;
	float* rotations; // [frame][J][4]
	float* root;      // [frame][3 translation + 4 rotation + dt]
	float beta[PLEAT_MAX_BETAS];
	uint32_t beta_count;
	float material[4];
} BenchMotion;

int BenchReadMotion( const char* path, BenchMotion* motion );
void BenchFreeMotion( BenchMotion* motion );
plFrameInput BenchMotionFrame( const BenchMotion* motion, uint32_t frame );

// Two workers, the calling thread and one helper thread: each task is cut into a few chunks claimed through one
// atomic word, so the caller runs whatever the helper has not claimed and never waits for a thread that is not
// running; finish waits only for chunks the helper already took. One task in flight at a time (the SDK enqueues and
// finishes at once).
typedef struct BenchTwoWorkers
{
	pthread_t thread;
	int started;
	_Atomic uint64_t claim; // generation << 40 | chunk count << 32 | next chunk (BenchClaimWord)
	atomic_uint done;       // chunks of the current generation completed
	atomic_int quit;
	uint32_t generation;    // written by the calling thread only
	plTaskFn* task;
	void* task_context;
	uint32_t item_count, chunk_size, chunk_count;
} BenchTwoWorkers;

// Starts the helper thread; 0 on failure.
int BenchTwoWorkers_Start( BenchTwoWorkers* pool );
void BenchTwoWorkers_Stop( BenchTwoWorkers* pool );
// Fills the task hooks of a context def (worker_count 2).
void BenchTwoWorkers_Install( BenchTwoWorkers* pool, plContextDef* def );

#endif
