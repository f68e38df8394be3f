// The crowd's batched blend-shape kernel alone (not a test): the kernel plStepInstances picks on this CPU over B
// instances of an N-vertex mesh with D shapes, fp32 and fp16 shapes, with its data in cache ("warm") and with the
// instances' base and output rows, the shapes, or both flushed from every cache level before each call (clflush), the
// state a crowd step leaves them in after its other stages. Why: the crowd's blend stage is slower than this kernel
// warm, and this tells how much of that is memory (docs/performance.md, "Where a crowd step's time goes").
//
// usage: pleat_bench_blend_batch [--vertices 4424] [--shapes 128] [--instances 64] [--iterations 21] [--row-align 64]
//                                [--batch-isa best|avx2] [--out blend.json]
// (--row-align: the alignment of every instance's rows; --batch-isa avx2 caps the kernels at the AVX2 twins.)
//
// Per case the median over the iterations of (the call's wall time) / B, and the multiply-adds a second (B · D · 3N
// over the call's time).
#define _POSIX_C_SOURCE 200809L
#include "bench_support.h"
#include "kernels.h"
#include "kernels_batch.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined( __x86_64__ ) && ( defined( __GNUC__ ) || defined( __clang__ ) )
#include <immintrin.h>
#define BLEND_CAN_FLUSH 1
#endif

#define BLEND_MAX_INSTANCES 256
#define BLEND_MAX_ITERATIONS 1001

typedef enum BlendCold
{
	BLEND_WARM,
	BLEND_COLD_INSTANCES, // each instance's base and output rows
	BLEND_COLD_SHAPES,
	BLEND_COLD_BOTH,
	BLEND_COLD_TLB, // cold_both, and the TLB's entries evicted too (a load from each page of a large buffer)
	BLEND_CASES
} BlendCold;

static const char* const k_caseNames[BLEND_CASES] = { "warm", "cold_instances", "cold_shapes", "cold_both", "cold_both_tlb" };

static void FlushBytes( const void* p, size_t bytes )
{
#if defined( BLEND_CAN_FLUSH )
	for ( size_t i = 0; i < bytes; i += 64 )
	{
		_mm_clflush( (const char*)p + i );
	}
	_mm_mfence();
#else
	(void)p;
	(void)bytes;
#endif
}

static size_t g_rowAlign = 64;

static uint32_t ArgU32( int argc, char** argv, const char* name, uint32_t fallback )
{
	for ( int i = 1; i + 1 < argc; ++i )
	{
		if ( strcmp( argv[i], name ) == 0 )
		{
			return (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		}
	}
	return fallback;
}

int main( int argc, char** argv )
{
	uint32_t N = ArgU32( argc, argv, "--vertices", 4424 ), D = ArgU32( argc, argv, "--shapes", 128 );
	uint32_t B = ArgU32( argc, argv, "--instances", 64 ), iterations = ArgU32( argc, argv, "--iterations", 21 );
	g_rowAlign = ArgU32( argc, argv, "--row-align", 64 );
	const char* out_path = NULL;
	plKernelSet max_isa = PLEAT_KERNEL_SET_AVX512;
	for ( int i = 1; i + 1 < argc; ++i )
	{
		out_path = strcmp( argv[i], "--out" ) == 0 ? argv[i + 1] : out_path;
		if ( strcmp( argv[i], "--batch-isa" ) == 0 )
		{
			max_isa = strcmp( argv[i + 1], "avx2" ) == 0 ? PLEAT_KERNEL_SET_AVX2 : PLEAT_KERNEL_SET_AVX512;
		}
	}
	plKernels single;
	plChooseKernels( &single, max_isa );
	plBatchKernels batch = *single.batch;
	if ( N == 0 || D == 0 || B == 0 || B > BLEND_MAX_INSTANCES || iterations == 0 || iterations > BLEND_MAX_ITERATIONS )
	{
		fprintf( stderr, "usage: pleat_bench_blend_batch [--vertices N] [--shapes D] [--instances 1..%d] "
						 "[--iterations 1..%d] [--out blend.json] (needs the batched kernels)\n",
				 BLEND_MAX_INSTANCES, BLEND_MAX_ITERATIONS );
		return 2;
	}
	size_t plane = (size_t)N * 3, shape_count = plane * D;
	float* shapes32 = (float*)aligned_alloc( 64, ( shape_count * 4 + 63 ) & ~(size_t)63 );
	uint16_t* shapes16 = (uint16_t*)aligned_alloc( 64, ( shape_count * 2 + 63 ) & ~(size_t)63 );
	float *out[BLEND_MAX_INSTANCES], *base[BLEND_MAX_INSTANCES], *weights[BLEND_MAX_INSTANCES];
	size_t row_bytes = ( plane * 4 + 63 ) & ~(size_t)63;
	int ok = shapes32 != NULL && shapes16 != NULL;
	for ( size_t i = 0; ok && i < shape_count; ++i )
	{
		shapes32[i] = (float)( ( i * 2654435761u ) % 2001 ) * 1e-5f - 0.01f; // ±1 cm, as a garment's shapes
		shapes16[i] = plFloatToHalf( shapes32[i] );
	}
	for ( uint32_t b = 0; b < B; ++b )
	{
		out[b] = ok ? (float*)aligned_alloc( g_rowAlign, row_bytes ) : NULL;
		base[b] = ok ? (float*)aligned_alloc( g_rowAlign, row_bytes ) : NULL;
		weights[b] = ok ? (float*)aligned_alloc( 64, ( D * 4 + 63 ) & ~(size_t)63 ) : NULL;
		ok = ok && out[b] != NULL && base[b] != NULL && weights[b] != NULL;
		for ( size_t i = 0; ok && i < plane; ++i )
		{
			base[b][i] = (float)( i % 977 ) * 1e-3f + (float)b * 1e-2f;
		}
		for ( uint32_t j = 0; ok && j < D; ++j )
		{
			weights[b][j] = (float)( ( j * 7 + b * 13 ) % 17 ) * 0.1f - 0.8f;
		}
	}
	if ( !ok )
	{
		fprintf( stderr, "pleat_bench_blend_batch: out of memory\n" );
		return 1;
	}
	FILE* f = BenchOpenOutput( "pleat_bench_blend_batch", out_path );
	if ( f == NULL )
	{
		return 1;
	}
	fprintf( f,
			 "{\n  \"batch_isa\": \"%s\",\n  \"vertices\": %u,\n  \"shapes\": %u,\n  \"instances\": %u,\n"
			 "  \"iterations\": %u,\n  \"loadavg_start\": %.2f,\n  \"results\": [\n",
			 batch.isa, N, D, B, iterations, BenchLoadAverage() );
	double samples[BLEND_MAX_ITERATIONS];
	size_t tlb_bytes = (size_t)256 << 20; // 65,536 pages: more than any TLB level holds
	volatile unsigned char* tlb_pages = (volatile unsigned char*)malloc( tlb_bytes );
	unsigned tlb_sink = 0;
	for ( size_t q = 0; tlb_pages != NULL && q < tlb_bytes; q += 4096 )
	{
		tlb_pages[q] = 1;
	}
	int first = 1;
	for ( int fp16 = 0; fp16 <= 1; ++fp16 )
	{
		const void* shapes = fp16 ? (const void*)shapes16 : (const void*)shapes32;
		plBlendShapes view = { shapes, fp16 ? PLEAT_SHAPES_F16 : PLEAT_SHAPES_F32, NULL };
		size_t shape_bytes = shape_count * ( fp16 ? 2 : 4 );
		for ( int c = 0; c < BLEND_CASES; ++c )
		{
#if !defined( BLEND_CAN_FLUSH )
			if ( c != BLEND_WARM )
			{
				continue;
			}
#endif
			if ( c == BLEND_COLD_TLB && tlb_pages == NULL )
			{
				continue;
			}
			for ( uint32_t it = 0; it <= iterations; ++it ) // iteration 0 warms up
			{
				if ( c == BLEND_COLD_TLB )
				{
					for ( size_t q = 0; q < tlb_bytes; q += 4096 )
					{
						tlb_sink += tlb_pages[q];
					}
				}
				if ( c == BLEND_COLD_INSTANCES || c == BLEND_COLD_BOTH || c == BLEND_COLD_TLB )
				{
					for ( uint32_t b = 0; b < B; ++b )
					{
						FlushBytes( base[b], row_bytes );
						FlushBytes( out[b], row_bytes );
					}
				}
				if ( c == BLEND_COLD_SHAPES || c == BLEND_COLD_BOTH || c == BLEND_COLD_TLB )
				{
					FlushBytes( shapes, shape_bytes );
				}
				double t0 = BenchNowUs();
				batch.blend_shapes_batch( out, (const float* const*)base, (const float* const*)weights, B, &view, D, N,
										  0, N );
				double us = BenchNowUs() - t0;
				if ( it > 0 )
				{
					samples[it - 1] = us / B;
				}
			}
			double us = BenchMedian( samples, iterations );
			fprintf( f, "%s    {\"shapes\": \"%s\", \"state\": \"%s\", \"us_per_instance\": %.2f, \"gmacs\": %.1f}",
					 first ? "" : ",\n", fp16 ? "fp16" : "fp32", k_caseNames[c], us,
					 us > 0.0 ? (double)D * plane / us * 1e-3 : 0.0 );
			first = 0;
		}
	}
	fprintf( f, "\n  ],\n  \"loadavg_end\": %.2f\n}\n", BenchLoadAverage() );
	BenchCloseOutput( f );
	for ( uint32_t b = 0; b < B; ++b )
	{
		free( out[b] );
		free( base[b] );
		free( weights[b] );
	}
	free( shapes32 );
	free( shapes16 );
	free( (void*)tlb_pages );
	(void)tlb_sink;
	return 0;
}
