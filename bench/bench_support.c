// Helpers the benchmark programs share (bench_support.h).
#define _POSIX_C_SOURCE 200809L
#include "bench_support.h"

#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

clockid_t g_benchClock = CLOCK_MONOTONIC;

double BenchNowUs( void )
{
	struct timespec ts;
	clock_gettime( g_benchClock, &ts );
	return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

static int BenchCompareDoubles( const void* a, const void* b )
{
	double x = *(const double*)a, y = *(const double*)b;
	return ( x > y ) - ( x < y );
}

double BenchMedian( double* values, size_t count )
{
	if ( count == 0 )
	{
		return 0.0;
	}
	qsort( values, count, sizeof( double ), BenchCompareDoubles );
	return count % 2 ? values[count / 2] : 0.5 * ( values[count / 2 - 1] + values[count / 2] );
}

uint8_t* BenchReadFile( const char* path, size_t* out_size )
{
	FILE* f = fopen( path, "rb" );
	if ( f == NULL )
	{
		return NULL;
	}
	fseek( f, 0, SEEK_END );
	long size = ftell( f );
	fseek( f, 0, SEEK_SET );
	uint8_t* bytes = size > 0 ? (uint8_t*)aligned_alloc( 64, ( (size_t)size + 63 ) & ~(size_t)63 ) : NULL;
	if ( bytes == NULL || fread( bytes, 1, (size_t)size, f ) != (size_t)size )
	{
		free( bytes );
		fclose( f );
		return NULL;
	}
	fclose( f );
	*out_size = (size_t)size;
	return bytes;
}

int BenchReadMotion( const char* path, BenchMotion* motion )
{
	size_t size = 0;
	uint8_t* bytes = BenchReadFile( path, &size );
	if ( bytes == NULL || size < 32 || memcmp( bytes, "PLGOLDEN", 8 ) != 0 )
	{
		free( bytes );
		return 0;
	}
	uint32_t header[6]; // version, frames, J, N, B, L (little-endian host)
	memcpy( header, bytes + 8, sizeof( header ) );
	uint32_t frames = header[1], joints = header[2], vertices = header[3], betas = header[4], latents = header[5];
	size_t per_frame = 4 * ( (size_t)joints * 4 + 3 + 4 + 1 + latents + (size_t)vertices * 6 );
	size_t offset = 32 + 4 * ( (size_t)betas + 4 );
	if ( betas > PLEAT_MAX_BETAS || frames == 0 || size < offset + per_frame * frames )
	{
		free( bytes );
		return 0;
	}
	motion->frame_count = frames;
	motion->joint_count = joints;
	motion->beta_count = betas;
	memcpy( motion->beta, bytes + 32, 4 * (size_t)betas );
	memcpy( motion->material, bytes + 32 + 4 * (size_t)betas, 16 );
	motion->rotations = (float*)malloc( 16 * (size_t)joints * frames );
	motion->root = (float*)malloc( 32 * (size_t)frames );
	for ( uint32_t f = 0; f < frames; ++f )
	{
		const uint8_t* p = bytes + offset + per_frame * f;
		memcpy( motion->rotations + (size_t)f * joints * 4, p, 16 * (size_t)joints );
		memcpy( motion->root + (size_t)f * 8, p + 16 * (size_t)joints, 32 );
	}
	free( bytes );
	return 1;
}

void BenchFreeMotion( BenchMotion* motion )
{
	free( motion->rotations );
	free( motion->root );
}

plFrameInput BenchMotionFrame( const BenchMotion* motion, uint32_t frame )
{
	const float* root = motion->root + (size_t)frame * 8;
	plFrameInput in;
	memset( &in, 0, sizeof( in ) );
	in.joint_rotations = motion->rotations + (size_t)frame * motion->joint_count * 4;
	in.joint_count = motion->joint_count;
	in.joint_stride_bytes = 16;
	in.root_translation = ( plVec3 ){ root[0], root[1], root[2] };
	in.root_rotation = ( plQuat ){ root[3], root[4], root[5], root[6] };
	in.dt_s = root[7];
	return in;
}

FILE* BenchOpenOutput( const char* program, const char* path )
{
	FILE* f = path != NULL ? fopen( path, "w" ) : stdout;
	if ( f == NULL )
	{
		fprintf( stderr, "%s: cannot write %s\n", program, path );
	}
	return f;
}

void BenchCloseOutput( FILE* f )
{
	if ( f != NULL && f != stdout )
	{
		fclose( f );
	}
}

// ---- two workers ----

#define BENCH_CHUNKS 4u

// The claim word: the generation, its chunk count and the next chunk. The count travels in the word the claim is made
// on: read from the pool instead, a helper still looking at a finished generation could see the next one's count
// (the caller writes it before publishing that generation), claim a chunk past the old end and run it as the new
// task's, one chunk more than the caller then waits for (a crowd benchmark hung so).
static inline uint64_t BenchClaimWord( uint32_t generation, uint32_t chunk_count, uint32_t chunk )
{
	return ( (uint64_t)( generation & 0xFFFFFFu ) << 40 ) | ( (uint64_t)( chunk_count & 0xFFu ) << 32 ) | chunk;
}

static inline uint32_t BenchClaimGeneration( uint64_t word )
{
	return (uint32_t)( word >> 40 );
}

// Claims and runs chunks of `generation` until none is left.
static void BenchRunChunks( BenchTwoWorkers* pool, uint32_t generation, uint32_t worker )
{
	uint64_t word = atomic_load_explicit( &pool->claim, memory_order_acquire );
	for ( ;; )
	{
		uint32_t chunk = (uint32_t)word, chunk_count = (uint32_t)( word >> 32 ) & 0xFFu;
		if ( BenchClaimGeneration( word ) != ( generation & 0xFFFFFFu ) || chunk >= chunk_count )
		{
			return;
		}
		if ( !atomic_compare_exchange_weak_explicit( &pool->claim, &word, word + 1, memory_order_acq_rel,
													 memory_order_acquire ) )
		{
			continue;
		}
		uint32_t begin = chunk * pool->chunk_size;
		uint32_t end = begin + pool->chunk_size < pool->item_count ? begin + pool->chunk_size : pool->item_count;
		pool->task( begin, end, worker, pool->task_context );
		atomic_fetch_add_explicit( &pool->done, 1u, memory_order_acq_rel );
		word = atomic_load_explicit( &pool->claim, memory_order_acquire );
	}
}

static void* BenchHelperMain( void* arg )
{
	BenchTwoWorkers* pool = (BenchTwoWorkers*)arg;
	uint32_t seen = 0;
	for ( ;; )
	{
		unsigned spins = 0;
		uint64_t word;
		while ( BenchClaimGeneration( word = atomic_load_explicit( &pool->claim, memory_order_acquire ) ) == seen )
		{
			if ( atomic_load_explicit( &pool->quit, memory_order_relaxed ) )
			{
				return NULL;
			}
			if ( ++spins > 20000 )
			{
				sched_yield();
			}
		}
		seen = BenchClaimGeneration( word );
		BenchRunChunks( pool, seen, 1 );
	}
}

static void* BenchEnqueue( plTaskFn* task, uint32_t item_count, uint32_t min_range, void* task_context,
						   void* user_context )
{
	BenchTwoWorkers* pool = (BenchTwoWorkers*)user_context;
	uint32_t chunk_size = ( item_count + BENCH_CHUNKS - 1 ) / BENCH_CHUNKS;
	chunk_size = chunk_size < min_range ? min_range : chunk_size;
	if ( chunk_size >= item_count )
	{
		task( 0, item_count, 0, task_context );
		return NULL;
	}
	pool->task = task;
	pool->task_context = task_context;
	pool->item_count = item_count;
	pool->chunk_size = chunk_size;
	pool->chunk_count = ( item_count + chunk_size - 1 ) / chunk_size;
	atomic_store_explicit( &pool->done, 0u, memory_order_relaxed );
	pool->generation += 1;
	atomic_store_explicit( &pool->claim, BenchClaimWord( pool->generation, pool->chunk_count, 0 ),
						   memory_order_release );
	BenchRunChunks( pool, pool->generation, 0 );
	return pool;
}

static void BenchFinish( void* user_task, void* user_context )
{
	(void)user_context;
	BenchTwoWorkers* pool = (BenchTwoWorkers*)user_task;
	unsigned spins = 0;
	while ( atomic_load_explicit( &pool->done, memory_order_acquire ) != pool->chunk_count )
	{
		if ( ++spins > 20000 )
		{
			sched_yield();
		}
	}
}

int BenchTwoWorkers_Start( BenchTwoWorkers* pool )
{
	memset( pool, 0, sizeof( *pool ) );
	atomic_init( &pool->claim, 0 );
	atomic_init( &pool->done, 0u );
	atomic_init( &pool->quit, 0 );
	pool->started = pthread_create( &pool->thread, NULL, BenchHelperMain, pool ) == 0;
	return pool->started;
}

void BenchTwoWorkers_Stop( BenchTwoWorkers* pool )
{
	if ( pool->started )
	{
		atomic_store_explicit( &pool->quit, 1, memory_order_relaxed );
		pthread_join( pool->thread, NULL );
		pool->started = 0;
	}
}

void BenchTwoWorkers_Install( BenchTwoWorkers* pool, plContextDef* def )
{
	def->enqueue_task = BenchEnqueue;
	def->finish_task = BenchFinish;
	def->task_context = pool;
	def->worker_count = 2;
}

double BenchLoadAverage( void )
{
	double load = -1.0;
	FILE* f = fopen( "/proc/loadavg", "r" );
	if ( f != NULL )
	{
		if ( fscanf( f, "%lf", &load ) != 1 )
		{
			load = -1.0;
		}
		fclose( f );
	}
	return load;
}
