// AVX2 + FMA (+ F16C) twin of plBlendShapesBatch_Scalar, and the batched twin of plBlendShapes_Avx2: per element it
// performs plBlendShapes_Avx2's arithmetic exactly — the base, then fma(w_j, D_j, ·) for j ascending, one rounding per
// shape (that kernel's vector lanes and its fmaf tail agree, so any element may take either path here too).
//
// The single-instance kernel streams the blend shapes four at a time over the whole vertex range (memory-bound). Here
// a tile of 16 elements (two vectors) × 4 instances keeps 8 accumulators in registers while j runs over all D shapes:
// per shape 2 shape loads and 4 weight broadcasts feed 8 FMAs, and the tile's column of every shape (D cache lines) is
// read from memory once, then from L1 for the other instances of the batch. The shapes' lines four tiles ahead, and
// each instance's base and output lines, are prefetched in software, the column's lines shared out over the instance
// groups: D strided streams plus two per instance are far more than the hardware prefetchers follow.
#include "kernels/kernels_batch.h"
#include "simd_avx2.h"

// An instance's base and output a few tiles ahead of element i: its two sequential streams are 2 of the batch's many
// interleaved ones, more than the hardware prefetchers follow (measured ~30 % faster at N = 4,424, 64 instances).
// Prefetches never fault, so running past the end of the arrays is harmless.
#define PLEAT_BLEND_PREFETCH_ELEMENTS 128

// What a tile call prefetches before its shape steps: its instances' base and output lines a few tiles ahead, and the
// shapes first, first + step, ... of the column four tiles ahead (column NULL: none). The column's D lines are shared
// out over the tile's instance groups: all at the tile's start they overflow the miss buffers and arrive late
// (pleat_bench_blend_batch).
typedef struct plBlendAhead
{
	const char* column;  // shape 0's line of that column
	size_t plane_bytes;  // from one shape's line to the next
	uint32_t first, step;
} plBlendAhead;

static inline void plPrefetchTile( const plBlendAhead* ahead, const float* const* base, float* const* out,
								   uint32_t count, uint32_t blend_count, size_t i )
{
	for ( uint32_t k = 0; k < count; ++k )
	{
		_mm_prefetch( (const char*)( base[k] + i + PLEAT_BLEND_PREFETCH_ELEMENTS ), _MM_HINT_T0 );
		__builtin_prefetch( out[k] + i + PLEAT_BLEND_PREFETCH_ELEMENTS, 1, 3 );
	}
	for ( uint32_t j = ahead->first; ahead->column != NULL && j < blend_count; j += ahead->step )
	{
		_mm_prefetch( ahead->column + (size_t)j * ahead->plane_bytes, _MM_HINT_T0 );
	}
}

// fp16 and int8 shapes of up to this many blend shapes are widened per tile into a 16 KB stack buffer.
#define PLEAT_BLEND_WIDEN_SHAPES 256

// Elements [i, i + 16) of four instances; the shapes' elements start at shape_i, plane apart.
static inline void plBlendTile16x4( float* const* out, const float* const* base, const float* const* weights,
									const plBlendShapes* shapes, uint32_t blend_count, size_t plane, size_t shape_i,
									size_t i, const plBlendAhead* ahead )
{
	const float *w0 = weights[0], *w1 = weights[1], *w2 = weights[2], *w3 = weights[3];
	plPrefetchTile( ahead, base, out, 4, blend_count, i );
	__m256 a0 = _mm256_loadu_ps( base[0] + i ), a1 = _mm256_loadu_ps( base[0] + i + 8 );
	__m256 b0 = _mm256_loadu_ps( base[1] + i ), b1 = _mm256_loadu_ps( base[1] + i + 8 );
	__m256 c0 = _mm256_loadu_ps( base[2] + i ), c1 = _mm256_loadu_ps( base[2] + i + 8 );
	__m256 d0 = _mm256_loadu_ps( base[3] + i ), d1 = _mm256_loadu_ps( base[3] + i + 8 );
	size_t o = shape_i;
	for ( uint32_t j = 0; j < blend_count; ++j, o += plane )
	{
		__m256 s0 = plLoadShape8( shapes, o ), s1 = plLoadShape8( shapes, o + 8 );
		__m256 w = _mm256_broadcast_ss( w0 + j );
		a0 = _mm256_fmadd_ps( w, s0, a0 );
		a1 = _mm256_fmadd_ps( w, s1, a1 );
		w = _mm256_broadcast_ss( w1 + j );
		b0 = _mm256_fmadd_ps( w, s0, b0 );
		b1 = _mm256_fmadd_ps( w, s1, b1 );
		w = _mm256_broadcast_ss( w2 + j );
		c0 = _mm256_fmadd_ps( w, s0, c0 );
		c1 = _mm256_fmadd_ps( w, s1, c1 );
		w = _mm256_broadcast_ss( w3 + j );
		d0 = _mm256_fmadd_ps( w, s0, d0 );
		d1 = _mm256_fmadd_ps( w, s1, d1 );
	}
	_mm256_storeu_ps( out[0] + i, a0 );
	_mm256_storeu_ps( out[0] + i + 8, a1 );
	_mm256_storeu_ps( out[1] + i, b0 );
	_mm256_storeu_ps( out[1] + i + 8, b1 );
	_mm256_storeu_ps( out[2] + i, c0 );
	_mm256_storeu_ps( out[2] + i + 8, c1 );
	_mm256_storeu_ps( out[3] + i, d0 );
	_mm256_storeu_ps( out[3] + i + 8, d1 );
}

// Elements [i, i + 16) of one instance.
static inline void plBlendTile16x1( float* out, const float* base, const float* w, const plBlendShapes* shapes,
									uint32_t blend_count, size_t plane, size_t shape_i, size_t i,
									const plBlendAhead* ahead )
{
	plPrefetchTile( ahead, &base, &out, 1, blend_count, i );
	__m256 a0 = _mm256_loadu_ps( base + i ), a1 = _mm256_loadu_ps( base + i + 8 );
	size_t o = shape_i;
	for ( uint32_t j = 0; j < blend_count; ++j, o += plane )
	{
		__m256 wj = _mm256_broadcast_ss( w + j );
		a0 = _mm256_fmadd_ps( wj, plLoadShape8( shapes, o ), a0 );
		a1 = _mm256_fmadd_ps( wj, plLoadShape8( shapes, o + 8 ), a1 );
	}
	_mm256_storeu_ps( out + i, a0 );
	_mm256_storeu_ps( out + i + 8, a1 );
}

// Elements [i, end) of one instance, fewer than 16: 8 at a time, then one at a time.
static inline void plBlendRest( float* out, const float* base, const float* w, const plBlendShapes* shapes,
								uint32_t blend_count, size_t plane, size_t i, size_t end )
{
	for ( ; i + 8 <= end; i += 8 )
	{
		__m256 a = _mm256_loadu_ps( base + i );
		size_t o = i;
		for ( uint32_t j = 0; j < blend_count; ++j, o += plane )
		{
			a = _mm256_fmadd_ps( _mm256_broadcast_ss( w + j ), plLoadShape8( shapes, o ), a );
		}
		_mm256_storeu_ps( out + i, a );
	}
	for ( ; i < end; ++i )
	{
		float a = base[i];
		size_t o = i;
		for ( uint32_t j = 0; j < blend_count; ++j, o += plane )
		{
			a = fmaf( w[j], plLoadShape1( shapes, o ), a );
		}
		out[i] = a;
	}
}

void plBlendShapesBatch_Avx2( float* const* out, const float* const* base, const float* const* weights,
							  uint32_t batch_count, const plBlendShapes* shapes, uint32_t blend_count,
							  uint32_t vertex_count, uint32_t v_begin, uint32_t v_end )
{
	const plBlendShapes sh = *shapes;
	size_t plane = (size_t)vertex_count * 3;
	size_t start = (size_t)v_begin * 3, end = (size_t)v_end * 3;
	// fp16 and int8 shapes: the tile's column of every shape widened to fp32 once (plShapeElement's values) instead
	// of once per instance group.
	float widened[PLEAT_BLEND_WIDEN_SHAPES * 16];
	int widen = sh.type != PLEAT_SHAPES_F32 && blend_count <= PLEAT_BLEND_WIDEN_SHAPES && batch_count > 4;
	size_t i = start;
	size_t element_bytes = plShapeBytes( sh.type );
	uint32_t groups = batch_count / 4 + batch_count % 4; // the tile calls below: fours, then ones
	for ( ; i + 16 <= end; i += 16 )
	{
		// the column four tiles ahead, its shapes shared out over the tile's instance groups
		plBlendAhead ahead = { i + 80 <= end ? (const char*)sh.data + ( i + 64 ) * element_bytes : NULL,
							   plane * element_bytes, 0, groups };
		plBlendShapes tile_shapes = sh;
		size_t tile_plane = plane, tile_i = i;
		if ( widen )
		{
			for ( uint32_t j = 0; j < blend_count; ++j )
			{
				size_t o = (size_t)j * plane + i;
				_mm256_storeu_ps( widened + j * 16, plLoadShape8( &sh, o ) );
				_mm256_storeu_ps( widened + j * 16 + 8, plLoadShape8( &sh, o + 8 ) );
			}
			tile_shapes = ( plBlendShapes ){ widened, PLEAT_SHAPES_F32, NULL };
			tile_plane = 16, tile_i = 0;
		}
		uint32_t b = 0;
		for ( ; b + 4 <= batch_count; b += 4, ++ahead.first )
		{
			plBlendTile16x4( out + b, base + b, weights + b, &tile_shapes, blend_count, tile_plane, tile_i, i,
							 &ahead );
		}
		for ( ; b < batch_count; ++b, ++ahead.first )
		{
			plBlendTile16x1( out[b], base[b], weights[b], &tile_shapes, blend_count, tile_plane, tile_i, i,
							 &ahead );
		}
	}
	for ( uint32_t b = 0; b < batch_count && i < end; ++b )
	{
		plBlendRest( out[b], base[b], weights[b], &sh, blend_count, plane, i, end );
	}
}
