// Per-phase timing of plInstance_Step and plStepInstances (step_phases.h); compiled only into the benchmark's
// pleat_phases library.
#define _POSIX_C_SOURCE 200809L
#include "step_phases.h"

#include <string.h>
#include <time.h>

double g_plStepPhaseUs[PLEAT_PHASE_COUNT];
double g_plBatchPhaseUs[PLEAT_BATCH_PHASE_COUNT];
int g_plStepPhaseClock = CLOCK_MONOTONIC; // the bench sets CLOCK_THREAD_CPUTIME_ID for --clock cpu
// Apart: a batch's prepare stage runs the single step's own marks for every instance.
static double s_last_us, s_batch_last_us;

static double plPhaseNowUs( void )
{
	struct timespec ts;
	clock_gettime( (clockid_t)g_plStepPhaseClock, &ts );
	return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

void plStepPhaseReset( void )
{
	memset( g_plStepPhaseUs, 0, sizeof( g_plStepPhaseUs ) );
}

void plStepPhaseStart( void )
{
	s_last_us = plPhaseNowUs();
}

// The time since *last into *total, and now becomes *last.
static void plPhaseAdd( double* total, double* last )
{
	double now = plPhaseNowUs();
	*total += now - *last;
	*last = now;
}

void plStepPhaseMark( plStepPhase phase )
{
	plPhaseAdd( &g_plStepPhaseUs[phase], &s_last_us );
}

void plBatchPhaseReset( void )
{
	memset( g_plBatchPhaseUs, 0, sizeof( g_plBatchPhaseUs ) );
}

void plBatchPhaseStart( void )
{
	s_batch_last_us = plPhaseNowUs();
}

void plBatchPhaseMark( plBatchPhase phase )
{
	plPhaseAdd( &g_plBatchPhaseUs[phase], &s_batch_last_us );
}
