// Crowd timings for docs/scene-budget.md and the "crowd" keys of out/bench/step.json (run by scripts/bench.sh; not a
// test): per-instance µs of plStepInstances against stepping the same number of instances one by one with
// plInstance_Step, in the same run.
//
// usage: pleat_bench_crowd --case case.bin --asset LABEL=PATH [--asset LABEL=PATH ...] [--counts 1,8,64,256]
//                          [--workers 1,2] [--seconds S] [--clock wall|cpu] [--out crowd.json]
//
// For every asset, worker count and instance count n: a context (two workers = this thread + one helper thread,
// bench_support.c), two sets of n instances of the asset with different β, each instance on its own phase of the
// case's motion. One timed iteration steps one set with plStepInstances and the other set one by one — the order
// alternating from one iteration to the next, so both see the same machine — until S seconds (default 0.5) have gone
// and at least 5 iterations ran; each number is the median over the iterations of (the call's time) / n. Both sets
// get the same inputs, so after the run their outputs are compared bit for bit ("bit_identical").
// "batch_vs_single_step" divides the batch's per-instance time by the one-by-one time of n = 1 for the same asset and
// workers (the single-instance step of the same run); the target is <= 0.25 at n = 64.
// --clock cpu is this thread's CPU time: with two workers it leaves out the helper's share, so wall (the default) is
// the clock for every comparison here.
#define _POSIX_C_SOURCE 200809L
#include "bench_support.h"
#include "pleat/pleat.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CROWD_MAX_ASSETS 8
#define CROWD_MAX_COUNTS 8
#define CROWD_MAX_ITERATIONS 4000

typedef struct CrowdResult
{
	const char* label;
	uint32_t workers, count, iterations;
	double batch_us, single_us; // per instance, medians
	int bit_identical;
	int all_ok;
} CrowdResult;

static uint32_t ParseList( const char* text, uint32_t* out, uint32_t capacity )
{
	uint32_t n = 0;
	while ( *text != '\0' && n < capacity )
	{
		char* end;
		out[n++] = (uint32_t)strtoul( text, &end, 10 );
		text = *end == ',' ? end + 1 : end;
		if ( end == text && *end != '\0' )
		{
			break;
		}
	}
	return n;
}

// Steps set a with plStepInstances and set b one by one (order by iteration parity), n instances each.
static int RunCrowd( const char* path, const BenchMotion* motion, uint32_t workers, BenchTwoWorkers* pool, uint32_t n,
					 double seconds, CrowdResult* result )
{
	plContextDef def = plDefaultContextDef();
	if ( workers == 2 )
	{
		BenchTwoWorkers_Install( pool, &def );
	}
	plContext context;
	if ( plCreateContext( &def, &context ) != PLEAT_RESULT_OK )
	{
		return 0;
	}
	plAssetDef adef = plDefaultAssetDef();
	adef.path = path;
	plAsset asset;
	plAssetInfo info;
	if ( plLoadAsset( context, &adef, &asset ) != PLEAT_RESULT_OK || plAsset_GetInfo( asset, &info ) != PLEAT_RESULT_OK )
	{
		plDestroyContext( context );
		return 0;
	}
	plInstance* sets = (plInstance*)calloc( 2 * (size_t)n, sizeof( plInstance ) );
	plFrameInput* inputs = (plFrameInput*)calloc( n, sizeof( plFrameInput ) );
	plResult* results = (plResult*)calloc( n, sizeof( plResult ) );
	double* batch_samples = (double*)calloc( CROWD_MAX_ITERATIONS, sizeof( double ) );
	double* single_samples = (double*)calloc( CROWD_MAX_ITERATIONS, sizeof( double ) );
	int ok = sets != NULL && inputs != NULL && results != NULL && batch_samples != NULL && single_samples != NULL;
	for ( uint32_t i = 0; ok && i < 2 * n; ++i )
	{
		uint32_t k = i % n;
		float beta[PLEAT_MAX_BETAS];
		memcpy( beta, motion->beta, sizeof( beta ) );
		beta[0] += -1.5f + 3.0f * (float)k / (float)( n > 1 ? n - 1 : 1 ); // different bodies, the same in a and b
		beta[1] += ( k % 3 ) * 0.5f - 0.5f;
		plInstanceDef idef = plDefaultInstanceDef();
		idef.asset = asset;
		idef.beta = beta;
		idef.beta_count = motion->beta_count < info.beta_count ? motion->beta_count : info.beta_count;
		idef.engine_joint_count = motion->joint_count;
		ok = idef.beta_count >= 2 && plCreateInstance( context, &idef, &sets[i] ) == PLEAT_RESULT_OK;
	}
	uint32_t frame = 0, iterations = 0;
	double started = BenchNowUs();
	result->all_ok = ok;
	while ( ok && iterations < CROWD_MAX_ITERATIONS )
	{
		for ( uint32_t k = 0; k < n; ++k )
		{
			inputs[k] = BenchMotionFrame( motion, ( frame + 37u * k ) % motion->frame_count );
		}
		double batch_us = 0.0, single_us = 0.0;
		for ( int pass = 0; pass < 2; ++pass )
		{
			int batch = ( pass == 0 ) == ( iterations % 2 == 0 );
			double t0 = BenchNowUs();
			if ( batch )
			{
				result->all_ok &= plStepInstances( context, sets, inputs, NULL, results, n ) >= 0;
				batch_us = BenchNowUs() - t0;
			}
			else
			{
				for ( uint32_t k = 0; k < n; ++k )
				{
					result->all_ok &= plInstance_Step( sets[n + k], &inputs[k], NULL ) >= 0;
				}
				single_us = BenchNowUs() - t0;
			}
		}
		frame += 1;
		if ( frame <= 2 )
		{
			continue; // warm-up: first steps, caches, page faults
		}
		batch_samples[iterations] = batch_us / n;
		single_samples[iterations] = single_us / n;
		iterations += 1;
		if ( iterations >= 5 && BenchNowUs() - started > seconds * 1e6 )
		{
			break;
		}
	}
	int identical = ok;
	for ( uint32_t k = 0; identical && k < n; ++k )
	{
		const float *pa, *pb, *na, *nb;
		plInstance_GetPositions( sets[k], &pa, NULL );
		plInstance_GetPositions( sets[n + k], &pb, NULL );
		plInstance_GetNormals( sets[k], &na, NULL );
		plInstance_GetNormals( sets[n + k], &nb, NULL );
		identical = memcmp( pa, pb, (size_t)info.vertex_count * 12 ) == 0 &&
					memcmp( na, nb, (size_t)info.vertex_count * 12 ) == 0;
	}
	result->workers = workers;
	result->count = n;
	result->iterations = iterations;
	result->batch_us = BenchMedian( batch_samples, iterations );
	result->single_us = BenchMedian( single_samples, iterations );
	result->bit_identical = identical;
	free( sets );
	free( inputs );
	free( results );
	free( batch_samples );
	free( single_samples );
	plDestroyContext( context );
	return ok;
}

int main( int argc, char** argv )
{
	const char* case_path = NULL;
	const char* out_path = NULL;
	const char* labels[CROWD_MAX_ASSETS];
	const char* paths[CROWD_MAX_ASSETS];
	uint32_t asset_count = 0;
	uint32_t counts[CROWD_MAX_COUNTS] = { 1, 8, 64, 256 }, count_count = 4;
	uint32_t workers[2] = { 1, 2 }, worker_count = 2;
	double seconds = 0.5;
	for ( int i = 1; i + 1 < argc; i += 2 )
	{
		if ( strcmp( argv[i], "--case" ) == 0 )
			case_path = argv[i + 1];
		else if ( strcmp( argv[i], "--out" ) == 0 )
			out_path = argv[i + 1];
		else if ( strcmp( argv[i], "--counts" ) == 0 )
			count_count = ParseList( argv[i + 1], counts, CROWD_MAX_COUNTS );
		else if ( strcmp( argv[i], "--workers" ) == 0 )
			worker_count = ParseList( argv[i + 1], workers, 2 );
		else if ( strcmp( argv[i], "--seconds" ) == 0 )
			seconds = strtod( argv[i + 1], NULL );
		else if ( strcmp( argv[i], "--clock" ) == 0 )
			g_benchClock = strcmp( argv[i + 1], "cpu" ) == 0 ? CLOCK_THREAD_CPUTIME_ID : CLOCK_MONOTONIC;
		else if ( strcmp( argv[i], "--asset" ) == 0 && asset_count < CROWD_MAX_ASSETS )
		{
			char* eq = strchr( argv[i + 1], '=' );
			if ( eq == NULL )
			{
				fprintf( stderr, "pleat_bench_crowd: --asset LABEL=PATH\n" );
				return 2;
			}
			*eq = '\0';
			labels[asset_count] = argv[i + 1];
			paths[asset_count++] = eq + 1;
		}
		else
		{
			fprintf( stderr, "pleat_bench_crowd: unknown option %s\n", argv[i] );
			return 2;
		}
	}
	BenchMotion motion;
	if ( case_path == NULL || asset_count == 0 || !BenchReadMotion( case_path, &motion ) )
	{
		fprintf( stderr, "usage: pleat_bench_crowd --case case.bin --asset LABEL=PATH [...] [--counts 1,8,64,256] "
						 "[--workers 1,2] [--seconds S] [--clock wall|cpu] [--out crowd.json]\n" );
		return 2;
	}
	for ( uint32_t w = 0; w < worker_count; ++w )
	{
		if ( workers[w] != 1 && workers[w] != 2 )
		{
			fprintf( stderr, "pleat_bench_crowd: --workers takes 1 and/or 2\n" );
			return 2;
		}
	}
	BenchTwoWorkers pool;

	// The kernel set every number was measured with (the SDK's default choice on this CPU).
	plContextDef probe_def = plDefaultContextDef();
	plContext probe;
	plKernelSet kernel_set = PLEAT_KERNEL_SET_SCALAR;
	if ( plCreateContext( &probe_def, &probe ) == PLEAT_RESULT_OK )
	{
		plContext_GetKernelSet( probe, &kernel_set );
		plDestroyContext( probe );
	}
	const char* isa = kernel_set == PLEAT_KERNEL_SET_AVX2 ? "avx2+fma+f16c" : "scalar";

	FILE* out = out_path != NULL ? fopen( out_path, "w" ) : stdout;
	if ( out == NULL )
	{
		fprintf( stderr, "pleat_bench_crowd: cannot write %s\n", out_path );
		return 1;
	}
	fprintf( out, "{\n  \"isa\": \"%s\",\n  \"clock\": \"%s\",\n  \"seconds_per_case\": %.2f,\n  \"results\": [\n", isa,
			 g_benchClock == CLOCK_MONOTONIC ? "wall" : "cpu", seconds );
	int first = 1, failed = 0;
	for ( uint32_t a = 0; a < asset_count; ++a )
	{
		for ( uint32_t w = 0; w < worker_count; ++w )
		{
			// The helper thread only while two-worker cases run: idle, it spins and yields, which a one-worker
			// measurement on a small machine would feel.
			if ( workers[w] == 2 && !BenchTwoWorkers_Start( &pool ) )
			{
				continue;
			}
			double single_step_us = 0.0;
			for ( uint32_t c = 0; c < count_count; ++c )
			{
				CrowdResult r;
				memset( &r, 0, sizeof( r ) );
				r.label = labels[a];
				if ( !RunCrowd( paths[a], &motion, workers[w], &pool, counts[c], seconds, &r ) )
				{
					fprintf( stderr, "pleat_bench_crowd: %s, %u workers, %u instances failed\n", labels[a], workers[w],
							 counts[c] );
					failed = 1;
					continue;
				}
				if ( counts[c] == 1 )
				{
					single_step_us = r.single_us;
				}
				fprintf( out,
						 "%s    {\"asset\": \"%s\", \"workers\": %u, \"instances\": %u, \"isa\": \"%s\", "
						 "\"batch_us_per_instance\": %.2f, \"one_by_one_us_per_instance\": %.2f, "
						 "\"batch_vs_one_by_one\": %.3f, \"batch_vs_single_step\": %.3f, \"iterations\": %u, "
						 "\"bit_identical\": %s, \"all_steps_ok\": %s}",
						 first ? "" : ",\n", r.label, r.workers, r.count, isa, r.batch_us, r.single_us,
						 r.single_us > 0.0 ? r.batch_us / r.single_us : 0.0,
						 single_step_us > 0.0 ? r.batch_us / single_step_us : 0.0, r.iterations,
						 r.bit_identical ? "true" : "false", r.all_ok ? "true" : "false" );
				fflush( out );
				first = 0;
				failed |= !r.bit_identical || !r.all_ok;
			}
			if ( workers[w] == 2 )
			{
				BenchTwoWorkers_Stop( &pool );
			}
		}
	}
	fprintf( out, "\n  ]\n}\n" );
	if ( out != stdout )
	{
		fclose( out );
	}
	BenchFreeMotion( &motion );
	return failed;
}
