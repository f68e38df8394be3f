// AVX-512 twin of plBlendShapesBatch_Avx2, and so a batched twin of plBlendShapes_Avx2: per element the base, then
// fma(w_j, D_j, ·) for j ascending, one rounding per shape — the same in any lane and any tile, so the 16-wide tiles,
// the masked tail and the AVX2 kernel's lanes and fmaf tail all give the same element.
//
// A tile of 48 elements (three 16-wide vectors) × 8 instances keeps 24 accumulators in registers while j runs over all
// D shapes: per shape 3 shape loads and 8 weight broadcasts feed 24 FMAs. The tile's column of every shape (D · 192
// bytes) is read from memory once and then from L1 for the other instance groups; fp16 and int8 shapes are widened
// once per tile into a stack buffer (plShapeElement's values). The shapes' lines four tiles ahead and each instance's
// base and output lines are prefetched in software (D strided streams plus two per instance are more than the hardware
// prefetchers follow), a line or a few per shape step rather than in bursts.
#include "kernels/kernels_batch.h"
#include "kernels/avx2/simd_avx2.h"

#include <immintrin.h>

#define PLEAT_BLEND512_VECTORS 3   // 16-wide vectors per tile: 48 elements
#define PLEAT_BLEND512_INSTANCES 8
// How far ahead (elements) each instance's base and output lines are prefetched: four tiles.
#define PLEAT_BLEND512_AHEAD 192
// fp16 and int8 shapes of up to this many blend shapes are widened per tile (128 · 48 floats, 24 KB on the stack);
// more take the AVX2 kernel (the same arithmetic).
#define PLEAT_BLEND512_WIDEN_SHAPES 128

#if defined( __GNUC__ ) || defined( __clang__ )
#define PLEAT_ALWAYS_INLINE inline __attribute__( ( always_inline ) )
#else
#define PLEAT_ALWAYS_INLINE inline
#endif

// Elements [i, i + 16 V) of instances [0, NB): out = base + Σ_j w_j · shapes[j · plane + shape_i ..] (fp32 shapes).
static PLEAT_ALWAYS_INLINE void plBlendTile512( const int V, const int NB, float* const* out, const float* const* base,
												const float* const* weights, const float* shapes, uint32_t blend_count,
												size_t plane, size_t shape_i, size_t i, const char* ahead,
												size_t ahead_plane_bytes, uint32_t ahead_first, uint32_t ahead_step )
{
	uint32_t ahead_next = ahead_first;
	__m512 acc[PLEAT_BLEND512_VECTORS][PLEAT_BLEND512_INSTANCES];
	const float* wb[PLEAT_BLEND512_INSTANCES];
	for ( int b = 0; b < NB; ++b )
	{
		wb[b] = weights[b];
		for ( int v = 0; v < V; ++v )
		{
			acc[v][b] = _mm512_loadu_ps( base[b] + i + 16 * v );
		}
	}
	const float* s = shapes + shape_i;
	for ( uint32_t j = 0; j < blend_count; ++j, s += plane )
	{
		__m512 d[PLEAT_BLEND512_VECTORS];
		for ( int v = 0; v < V; ++v )
		{
			d[v] = _mm512_loadu_ps( s + 16 * v );
		}
		if ( ahead != NULL && j == ahead_next )
		{
			// a later tile's lines of shape j, spread over the work of every instance group of this tile (group g
			// takes shapes g, g + groups, ...): a burst of D · V prefetches overflows the miss buffers, and the
			// column then arrives late
			ahead_next += ahead_step;
			for ( int v = 0; v < V; ++v )
			{
				_mm_prefetch( ahead + (size_t)j * ahead_plane_bytes + 64 * v, _MM_HINT_T0 );
			}
		}
		// Line j of the tile's NB · V base lines and output lines a few tiles ahead, one of each per shape step (all
		// that are left at the last): issued at once at the tile's start they overflow the miss buffers, as the
		// shapes' would, and arrive late. Spread, a crowd's blend with its rows out of cache runs 12-17 % faster
		// (pleat_bench_blend_batch).
		uint32_t lines_end = j + 1 == blend_count ? (uint32_t)( NB * V ) : j + 1;
		for ( uint32_t k = j; k < lines_end && k < (uint32_t)( NB * V ); ++k )
		{
			uint32_t b = k / (uint32_t)V, v = k % (uint32_t)V;
			_mm_prefetch( (const char*)( base[b] + i + PLEAT_BLEND512_AHEAD + 16 * v ), _MM_HINT_T0 );
			__builtin_prefetch( out[b] + i + PLEAT_BLEND512_AHEAD + 16 * v, 1, 3 );
		}
		for ( int b = 0; b < NB; ++b )
		{
			__m512 w = _mm512_set1_ps( wb[b][j] );
			for ( int v = 0; v < V; ++v )
			{
				acc[v][b] = _mm512_fmadd_ps( w, d[v], acc[v][b] );
			}
		}
	}
	for ( int b = 0; b < NB; ++b )
	{
		for ( int v = 0; v < V; ++v )
		{
			_mm512_storeu_ps( out[b] + i + 16 * v, acc[v][b] );
		}
	}
}

static void plBlendTile( int V, int NB, float* const* out, const float* const* base, const float* const* weights,
						 const float* shapes, uint32_t blend_count, size_t plane, size_t shape_i, size_t i,
						 const char* ahead, size_t ahead_plane_bytes, uint32_t ahead_first, uint32_t ahead_step )
{
#define PLEAT_TILE_CASE( vectors, n )                                                                                  \
	case n:                                                                                                            \
		plBlendTile512( vectors, n, out, base, weights, shapes, blend_count, plane, shape_i, i, ahead,                \
						ahead_plane_bytes, ahead_first, ahead_step );                                                  \
		return;
	if ( V == PLEAT_BLEND512_VECTORS )
	{
		switch ( NB )
		{
			PLEAT_TILE_CASES_1_TO_8( PLEAT_TILE_CASE, 3 )
		default:
			return;
		}
	}
	switch ( NB ) // one vector: the 16-element tiles after the 48-element ones
	{
		PLEAT_TILE_CASES_1_TO_8( PLEAT_TILE_CASE, 1 )
	default:
		return;
	}
#undef PLEAT_TILE_CASE
}

// Elements [i, end), fewer than 16, of one instance: masked 16-wide (lanes past end are neither read nor written).
static void plBlendTail( float* out, const float* base, const float* w, const plBlendShapes* shapes,
						 uint32_t blend_count, size_t plane, size_t i, size_t end )
{
	__mmask16 mask = (__mmask16)( ( 1u << ( end - i ) ) - 1u );
	__m512 a = _mm512_maskz_loadu_ps( mask, base + i );
	size_t o = i;
	for ( uint32_t j = 0; j < blend_count; ++j, o += plane )
	{
		__m512 d;
		if ( shapes->type == PLEAT_SHAPES_I8 )
		{
			__m128i q = _mm_maskz_loadu_epi8( mask, (const int8_t*)shapes->data + o );
			d = _mm512_cvtepi32_ps( _mm512_cvtepi8_epi32( q ) );
		}
		else
		{
			d = shapes->type == PLEAT_SHAPES_F16
					? _mm512_cvtph_ps( _mm256_maskz_loadu_epi16( mask, (const uint16_t*)shapes->data + o ) )
					: _mm512_maskz_loadu_ps( mask, (const float*)shapes->data + o );
		}
		a = _mm512_fmadd_ps( _mm512_set1_ps( w[j] ), d, a );
	}
	_mm512_mask_storeu_ps( out + i, mask, a );
}

void plBlendShapesBatch_Avx512( float* const* out, const float* const* base, const float* const* weights,
								uint32_t batch_count, const plBlendShapes* shapes, uint32_t blend_count,
								uint32_t vertex_count, uint32_t v_begin, uint32_t v_end )
{
	const plBlendShapes sh = *shapes;
	if ( sh.type != PLEAT_SHAPES_F32 && blend_count > PLEAT_BLEND512_WIDEN_SHAPES )
	{
		plBlendShapesBatch_Avx2( out, base, weights, batch_count, &sh, blend_count, vertex_count, v_begin, v_end );
		return;
	}
	const size_t tile = 16 * PLEAT_BLEND512_VECTORS;
	size_t plane = (size_t)vertex_count * 3;
	size_t start = (size_t)v_begin * 3, end = (size_t)v_end * 3;
	_Alignas( 64 ) float widened[PLEAT_BLEND512_WIDEN_SHAPES * 16 * PLEAT_BLEND512_VECTORS];
	size_t i = start;
	while ( i + 16 <= end )
	{
		int vectors = i + tile <= end ? PLEAT_BLEND512_VECTORS : 1;
		size_t width = (size_t)vectors * 16;
		// the column of the tile four ahead (fp16, int8: its bytes are fewer, in the same lines or fewer)
		size_t element_bytes = plShapeBytes( sh.type );
		const char* ahead = i + 5 * tile <= end ? (const char*)sh.data + ( i + 4 * tile ) * element_bytes : NULL;
		const float* tile_shapes = (const float*)sh.data;
		size_t tile_plane = plane, tile_i = i;
		if ( sh.type != PLEAT_SHAPES_F32 )
		{
			for ( uint32_t j = 0; j < blend_count; ++j )
			{
				size_t o = (size_t)j * plane + i;
				for ( int v = 0; v < vectors; ++v, o += 16 )
				{
					__m512 d;
					if ( sh.type == PLEAT_SHAPES_I8 )
					{
						const __m128i* src = (const __m128i*)( (const int8_t*)sh.data + o );
						d = _mm512_cvtepi32_ps( _mm512_cvtepi8_epi32( _mm_loadu_si128( src ) ) );
					}
					else
					{
						d = _mm512_cvtph_ps( _mm256_loadu_si256( (const __m256i*)( (const uint16_t*)sh.data + o ) ) );
					}
					_mm512_store_ps( widened + j * width + 16 * v, d );
				}
			}
			tile_shapes = widened, tile_plane = width, tile_i = 0;
		}
		uint32_t groups = ( batch_count + PLEAT_BLEND512_INSTANCES - 1 ) / PLEAT_BLEND512_INSTANCES;
		for ( uint32_t b = 0; b < batch_count; b += PLEAT_BLEND512_INSTANCES )
		{
			int n = batch_count - b >= PLEAT_BLEND512_INSTANCES ? PLEAT_BLEND512_INSTANCES : (int)( batch_count - b );
			plBlendTile( vectors, n, out + b, base + b, weights + b, tile_shapes, blend_count, tile_plane, tile_i, i,
						 ahead, plane * element_bytes, b / PLEAT_BLEND512_INSTANCES, groups );
		}
		i += width;
	}
	for ( uint32_t b = 0; b < batch_count && i < end; ++b )
	{
		plBlendTail( out[b], base[b], weights[b], &sh, blend_count, plane, i, end );
	}
}
