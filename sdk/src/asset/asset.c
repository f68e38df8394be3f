// The asset loader (docs/asset-format.md v1.0): structure and overflow checks before any pointer into the buffer is
// made, then the CRC-32, then meaning (dims, index ranges, finite values). Loads from memory (in place or copied to an
// aligned block) or from a file.
#if !defined( _WIN32 ) && !defined( _POSIX_C_SOURCE )
#define _POSIX_C_SOURCE 200809L // stat, open, fstat, fcntl, fdopen (plOpenRegularFile)
#endif
#include "asset.h"
#include "core/core.h"
#include "jobs/jobs.h"
#include "jobs/jobs_batch.h"
#include "kernels/kernels_batch.h"
#include "onnx_model.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#if !defined( _WIN32 )
#include <fcntl.h>
#include <unistd.h>
#endif

#if defined( __BYTE_ORDER__ ) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "Pleat assets are little-endian and read in place; a big-endian port needs a byte-swapping loader"
#endif

#define PLEAT_HEADER_SIZE 128u
#define PLEAT_SECTION_ENTRY_SIZE 48u
#define PLEAT_MAX_SECTIONS 256u
#define PLEAT_CONF_SIZE 256u

enum
{
	PLEAT_DTYPE_F32 = 1,
	PLEAT_DTYPE_F16 = 2,
	PLEAT_DTYPE_U32 = 3,
	PLEAT_DTYPE_U16 = 4,
	PLEAT_DTYPE_I32 = 5,
	PLEAT_DTYPE_U8 = 6,
};

typedef struct plSection
{
	uint32_t fourcc;
	uint32_t dtype;
	uint32_t rank;
	uint64_t offset;
	uint64_t size;
	uint32_t dims[4];
} plSection;

typedef struct plSectionTable
{
	plSection sections[PLEAT_MAX_SECTIONS];
	uint32_t count;
} plSectionTable;

static uint16_t plReadU16( const uint8_t* p )
{
	return (uint16_t)( p[0] | ( p[1] << 8 ) );
}

static uint32_t plReadU32( const uint8_t* p )
{
	return (uint32_t)p[0] | ( (uint32_t)p[1] << 8 ) | ( (uint32_t)p[2] << 16 ) | ( (uint32_t)p[3] << 24 );
}

static uint64_t plReadU64( const uint8_t* p )
{
	return (uint64_t)plReadU32( p ) | ( (uint64_t)plReadU32( p + 4 ) << 32 );
}

static float plReadF32( const uint8_t* p )
{
	uint32_t u = plReadU32( p );
	float f;
	memcpy( &f, &u, sizeof( f ) );
	return f;
}

static uint32_t plFourcc( const char* s )
{
	return (uint32_t)(uint8_t)s[0] | ( (uint32_t)(uint8_t)s[1] << 8 ) | ( (uint32_t)(uint8_t)s[2] << 16 ) |
		   ( (uint32_t)(uint8_t)s[3] << 24 );
}

uint32_t plCrc32( uint32_t crc, const uint8_t* data, size_t size )
{
	// Reflected IEEE 802.3 polynomial, as zlib.crc32, eight bytes per step ("slicing-by-8": table k advances a byte
	// k further), ~5× the byte-wise loop on a multi-MB asset. The tables (8 KiB) are rebuilt per call, negligible next
	// to a load, so there is no lazily initialised global. Bytes are combined explicitly: endian-independent.
	uint32_t table[8][256];
	for ( uint32_t i = 0; i < 256; ++i )
	{
		uint32_t c = i;
		for ( int k = 0; k < 8; ++k )
		{
			c = ( c & 1u ) ? 0xEDB88320u ^ ( c >> 1 ) : c >> 1;
		}
		table[0][i] = c;
	}
	for ( uint32_t i = 0; i < 256; ++i )
	{
		for ( int k = 1; k < 8; ++k )
		{
			uint32_t previous = table[k - 1][i];
			table[k][i] = ( previous >> 8 ) ^ table[0][previous & 0xFFu];
		}
	}
	crc = ~crc;
	for ( ; size >= 8; size -= 8, data += 8 )
	{
		uint32_t lo = crc ^ ( (uint32_t)data[0] | ( (uint32_t)data[1] << 8 ) | ( (uint32_t)data[2] << 16 ) |
							  ( (uint32_t)data[3] << 24 ) );
		uint32_t hi = (uint32_t)data[4] | ( (uint32_t)data[5] << 8 ) | ( (uint32_t)data[6] << 16 ) |
					  ( (uint32_t)data[7] << 24 );
		crc = table[7][lo & 0xFFu] ^ table[6][( lo >> 8 ) & 0xFFu] ^ table[5][( lo >> 16 ) & 0xFFu] ^ table[4][lo >> 24] ^
			  table[3][hi & 0xFFu] ^ table[2][( hi >> 8 ) & 0xFFu] ^ table[1][( hi >> 16 ) & 0xFFu] ^ table[0][hi >> 24];
	}
	for ( ; size > 0; --size, ++data )
	{
		crc = table[0][( crc ^ *data ) & 0xFFu] ^ ( crc >> 8 );
	}
	return ~crc;
}

static uint32_t plDtypeSize( uint32_t dtype )
{
	switch ( dtype )
	{
		case PLEAT_DTYPE_F32:
		case PLEAT_DTYPE_U32:
		case PLEAT_DTYPE_I32:
			return 4;
		case PLEAT_DTYPE_F16:
		case PLEAT_DTYPE_U16:
			return 2;
		case PLEAT_DTYPE_U8:
			return 1;
		default:
			return 0;
	}
}

// ---- structure ----

static plResult plParseHeader( const uint8_t* data, size_t size, int skip_checksum, plSectionTable* table,
							   uint32_t* out_flags )
{
	if ( size < 8 )
	{
		return PLEAT_RESULT_TRUNCATED;
	}
	if ( memcmp( data, "PLEATAST", 8 ) != 0 )
	{
		return PLEAT_RESULT_BAD_MAGIC;
	}
	if ( size < 12 )
	{
		return PLEAT_RESULT_TRUNCATED;
	}
	uint16_t major = plReadU16( data + 8 );
	if ( major < PLEAT_ASSET_VERSION_MAJOR )
	{
		return PLEAT_RESULT_LEGACY_VERSION;
	}
	if ( major > PLEAT_ASSET_VERSION_MAJOR )
	{
		return PLEAT_RESULT_UNSUPPORTED_VERSION;
	}
	if ( size < PLEAT_HEADER_SIZE )
	{
		return PLEAT_RESULT_TRUNCATED;
	}
	uint32_t header_size = plReadU32( data + 12 );
	uint64_t file_size = plReadU64( data + 16 );
	uint32_t section_count = plReadU32( data + 24 );
	uint32_t flags = plReadU32( data + 28 );
	uint64_t table_offset = plReadU64( data + 32 );
	uint32_t checksum = plReadU32( data + 40 );
	if ( file_size > (uint64_t)size )
	{
		return PLEAT_RESULT_TRUNCATED;
	}
	if ( file_size != (uint64_t)size || header_size < PLEAT_HEADER_SIZE || header_size > size ||
		 section_count < 1 || section_count > PLEAT_MAX_SECTIONS || ( flags & ~1u ) != 0 || table_offset < header_size ||
		 table_offset > size || (uint64_t)section_count * PLEAT_SECTION_ENTRY_SIZE > size - table_offset )
	{
		return PLEAT_RESULT_MALFORMED_ASSET;
	}
	if ( !skip_checksum )
	{
		static const uint8_t zeros[4] = { 0, 0, 0, 0 };
		uint32_t crc = plCrc32( 0, data, 40 );
		crc = plCrc32( crc, zeros, 4 );
		crc = plCrc32( crc, data + 44, size - 44 );
		if ( crc != checksum )
		{
			return PLEAT_RESULT_CHECKSUM_MISMATCH;
		}
	}
	uint64_t table_end = table_offset + (uint64_t)section_count * PLEAT_SECTION_ENTRY_SIZE;
	table->count = section_count;
	for ( uint32_t i = 0; i < section_count; ++i )
	{
		const uint8_t* e = data + table_offset + (uint64_t)i * PLEAT_SECTION_ENTRY_SIZE;
		plSection* s = &table->sections[i];
		s->fourcc = plReadU32( e );
		s->dtype = plReadU32( e + 4 );
		s->rank = plReadU32( e + 8 );
		uint32_t reserved = plReadU32( e + 12 );
		s->offset = plReadU64( e + 16 );
		s->size = plReadU64( e + 24 );
		uint32_t dtype_size = plDtypeSize( s->dtype );
		if ( dtype_size == 0 || s->rank < 1 || s->rank > 4 || reserved != 0 || ( s->offset % 64u ) != 0 ||
			 s->offset < table_end || s->offset > size || s->size > size - s->offset )
		{
			return PLEAT_RESULT_MALFORMED_ASSET;
		}
		uint64_t elements = 1;
		for ( uint32_t d = 0; d < 4; ++d )
		{
			s->dims[d] = plReadU32( e + 32 + 4 * d );
			if ( d >= s->rank && s->dims[d] != 1 )
			{
				return PLEAT_RESULT_MALFORMED_ASSET;
			}
			// The product stays below 2^64 because each factor is checked against the file size first.
			if ( s->dims[d] != 0 && elements > (uint64_t)size / s->dims[d] )
			{
				return PLEAT_RESULT_MALFORMED_ASSET;
			}
			elements *= s->dims[d];
		}
		if ( elements * dtype_size != s->size )
		{
			return PLEAT_RESULT_MALFORMED_ASSET;
		}
		for ( uint32_t j = 0; j < i; ++j )
		{
			const plSection* o = &table->sections[j];
			if ( o->fourcc == s->fourcc )
			{
				return PLEAT_RESULT_MALFORMED_ASSET;
			}
			if ( s->size != 0 && o->size != 0 && s->offset < o->offset + o->size && o->offset < s->offset + s->size )
			{
				return PLEAT_RESULT_MALFORMED_ASSET;
			}
		}
	}
	*out_flags = flags;
	return PLEAT_RESULT_OK;
}

// ---- meaning ----

static const plSection* plFindSection( const plSectionTable* table, const char* fourcc )
{
	uint32_t code = plFourcc( fourcc );
	for ( uint32_t i = 0; i < table->count; ++i )
	{
		if ( table->sections[i].fourcc == code )
		{
			return &table->sections[i];
		}
	}
	return NULL;
}

// Finds a required section with the given dtype and dims (rank = dim_count); NULL if missing or different.
static const void* plRequire( const uint8_t* data, const plSectionTable* table, const char* fourcc, uint32_t dtype,
							  uint32_t dim_count, uint32_t d0, uint32_t d1, uint32_t d2 )
{
	const plSection* s = plFindSection( table, fourcc );
	if ( s == NULL || s->dtype != dtype || s->rank != dim_count )
	{
		return NULL;
	}
	uint32_t expected[3] = { d0, d1, d2 };
	for ( uint32_t d = 0; d < dim_count; ++d )
	{
		if ( s->dims[d] != expected[d] )
		{
			return NULL;
		}
	}
	// A zero-sized section still needs a valid pointer; offset is inside the file.
	return data + s->offset;
}

static int plAllFiniteHalf( const uint16_t* v, uint64_t count )
{
	for ( uint64_t i = 0; i < count; ++i )
	{
		if ( ( v[i] & 0x7C00u ) == 0x7C00u )
		{
			return 0;
		}
	}
	return 1;
}

// A weight tensor [d0][d1] (or [d0][d1][d2]) that may be fp32 or fp16; returns NULL if missing, wrong, or non-finite.
static const void* plRequireWeights( const uint8_t* data, const plSectionTable* table, const char* fourcc,
									 uint32_t flags, uint32_t dim_count, uint32_t d0, uint32_t d1, uint32_t d2,
									 int* out_fp16 )
{
	const plSection* s = plFindSection( table, fourcc );
	if ( s == NULL )
	{
		return NULL;
	}
	int fp16 = s->dtype == PLEAT_DTYPE_F16;
	if ( fp16 && ( flags & 1u ) == 0 )
	{
		return NULL;
	}
	const void* p = plRequire( data, table, fourcc, fp16 ? PLEAT_DTYPE_F16 : PLEAT_DTYPE_F32, dim_count, d0, d1, d2 );
	if ( p == NULL )
	{
		return NULL;
	}
	uint64_t count = (uint64_t)d0 * d1 * ( dim_count == 3 ? d2 : 1u );
	if ( fp16 ? !plAllFiniteHalf( (const uint16_t*)p, count ) : !plAllFiniteFloats( (const float*)p, count ) )
	{
		return NULL;
	}
	*out_fp16 = fp16;
	return p;
}

static plResult plParseLayers( const uint8_t* data, const plSectionTable* table, uint32_t flags, char prefix_w0,
							   char prefix_w1, char prefix_b1, uint32_t count, uint32_t first_in, uint32_t last_out,
							   plLayer* layers )
{
	uint32_t in_count = first_in;
	for ( uint32_t i = 0; i < count; ++i )
	{
		char wname[5] = { prefix_w0, prefix_w1, 'W', (char)( '0' + i ), 0 };
		char bname[5] = { prefix_w0, prefix_b1, 'B', (char)( '0' + i ), 0 };
		if ( prefix_b1 == 'C' )
		{
			// Decoder sections are DCWi / DCBi, latent predictor LPWi / LPBi.
			bname[1] = 'C';
		}
		const plSection* ws = plFindSection( table, wname );
		if ( ws == NULL || ws->rank != 2 || ws->dims[1] != in_count || ws->dims[0] == 0 )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		uint32_t out_count = ws->dims[0];
		if ( i + 1 == count && out_count != last_out )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		int fp16 = 0;
		const void* w = plRequireWeights( data, table, wname, flags, 2, out_count, in_count, 1, &fp16 );
		const float* b = (const float*)plRequire( data, table, bname, PLEAT_DTYPE_F32, 1, out_count, 1, 1 );
		if ( w == NULL || b == NULL || !plAllFiniteFloats( b, out_count ) )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		layers[i].weight = w;
		layers[i].weight_fp16 = fp16;
		layers[i].bias = b;
		layers[i].in_count = in_count;
		layers[i].out_count = out_count;
		plFindLayerBlocks( &layers[i] ); // a packed ensemble's block-diagonal layers (layer_blocks.c)
		in_count = out_count;
	}
	return PLEAT_RESULT_OK;
}

// Skin rows [N][K]: finite, non-negative weights summing to 1 ± 1e-3, joints < J.
static int plSkinRowsValid( const uint16_t* indices, const float* weights, uint32_t N, uint32_t K, uint32_t J )
{
	for ( uint32_t v = 0; v < N; ++v )
	{
		double sum = 0.0;
		for ( uint32_t k = 0; k < K; ++k )
		{
			float w = weights[(size_t)v * K + k];
			if ( !isfinite( w ) || w < 0.0f || indices[(size_t)v * K + k] >= J )
			{
				return 0;
			}
			sum += w;
		}
		if ( fabs( sum - 1.0 ) > 1e-3 )
		{
			return 0;
		}
	}
	return 1;
}

// The optional body-contact block: BANC, BASH, BANN, BASI, BASW, all or none (asset 1.1: one point per vertex), and
// BACA (asset 1.2: each vertex's candidate points, which sets the point count P to BANC's rows) and BARG (1.2: each
// point's ring of points, for the posed body's normal there).
static plResult plParseBodyContact( const uint8_t* data, const plSectionTable* table, plAssetData* a )
{
	static const char* const tags[5] = { "BANC", "BASH", "BANN", "BASI", "BASW" };
	int present = 0;
	for ( int t = 0; t < 5; ++t )
	{
		present += plFindSection( table, tags[t] ) != NULL;
	}
	const plSection* baca = plFindSection( table, "BACA" );
	const plSection* barg = plFindSection( table, "BARG" );
	if ( present == 0 )
	{
		return baca == NULL && barg == NULL ? PLEAT_RESULT_OK : PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	const plSection* basi = plFindSection( table, "BASI" );
	const plSection* banc = plFindSection( table, "BANC" );
	if ( present != 5 || basi->rank != 2 || basi->dims[1] < 1 || basi->dims[1] > PLEAT_MAX_INFLUENCES ||
		 banc->rank != 2 )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	uint32_t N = a->vertex_count, B = a->beta_count, Ka = basi->dims[1];
	uint32_t P = N, C = 1;
	if ( baca != NULL )
	{
		if ( baca->rank != 2 || baca->dims[1] < 1 || baca->dims[1] > PLEAT_MAX_CONTACT_CANDIDATES ||
			 banc->dims[0] < 1 || banc->dims[0] >= PLEAT_NO_CONTACT_CANDIDATE )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		P = banc->dims[0];
		C = baca->dims[1];
		a->body_anchor_candidates = (const uint16_t*)plRequire( data, table, "BACA", PLEAT_DTYPE_U16, 2, N, C, 1 );
		if ( a->body_anchor_candidates == NULL )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		for ( uint64_t i = 0; i < (uint64_t)N * C; ++i )
		{
			uint16_t c = a->body_anchor_candidates[i];
			if ( c >= P && c != PLEAT_NO_CONTACT_CANDIDATE )
			{
				return PLEAT_RESULT_INVALID_ASSET_DATA;
			}
		}
	}
	a->body_anchors = (const float*)plRequire( data, table, "BANC", PLEAT_DTYPE_F32, 2, P, 3, 1 );
	a->body_anchor_shape = (const float*)plRequire( data, table, "BASH", PLEAT_DTYPE_F32, 3, B, P, 3 );
	a->body_anchor_normals = (const float*)plRequire( data, table, "BANN", PLEAT_DTYPE_F32, 2, P, 3, 1 );
	a->body_anchor_skin_indices = (const uint16_t*)plRequire( data, table, "BASI", PLEAT_DTYPE_U16, 2, P, Ka, 1 );
	a->body_anchor_skin_weights = (const float*)plRequire( data, table, "BASW", PLEAT_DTYPE_F32, 2, P, Ka, 1 );
	if ( a->body_anchors == NULL || a->body_anchor_shape == NULL || a->body_anchor_normals == NULL ||
		 a->body_anchor_skin_indices == NULL || a->body_anchor_skin_weights == NULL ||
		 !plAllFiniteFloats( a->body_anchors, (uint64_t)P * 3 ) ||
		 !plAllFiniteFloats( a->body_anchor_shape, (uint64_t)B * P * 3 ) ||
		 !plAllFiniteFloats( a->body_anchor_normals, (uint64_t)P * 3 ) ||
		 !plSkinRowsValid( a->body_anchor_skin_indices, a->body_anchor_skin_weights, P, Ka, a->joint_count ) )
	{
		a->body_anchors = NULL;
		a->body_anchor_candidates = NULL;
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	// Each normal is a unit vector (± 1e-3, as pleat-pack writes it) or zero (a point that never anchors).
	for ( uint32_t p = 0; p < P; ++p )
	{
		const float* n = a->body_anchor_normals + (size_t)p * 3;
		double len = sqrt( (double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2] );
		if ( len != 0.0 && fabs( len - 1.0 ) > 1e-3 )
		{
			a->body_anchors = NULL;
			a->body_anchor_candidates = NULL;
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
	}
	// BARG (1.2, optional): per point a ring of 3..R point indices < P, then empty entries (or none at all).
	if ( barg != NULL )
	{
		uint32_t R = barg->rank == 2 ? barg->dims[1] : 0;
		a->body_anchor_ring = R >= 3 && R <= PLEAT_MAX_POINT_RING
								  ? (const uint16_t*)plRequire( data, table, "BARG", PLEAT_DTYPE_U16, 2, P, R, 1 )
								  : NULL;
		int valid = a->body_anchor_ring != NULL;
		for ( uint32_t p = 0; valid && p < P; ++p )
		{
			const uint16_t* ring = a->body_anchor_ring + (size_t)p * R;
			uint32_t m = 0;
			while ( m < R && ring[m] < P )
			{
				m++;
			}
			valid = m == 0 || m >= 3;
			for ( uint32_t i = m; valid && i < R; ++i )
			{
				valid = ring[i] == PLEAT_NO_CONTACT_CANDIDATE; // after the ring only empty entries
			}
		}
		if ( !valid )
		{
			a->body_anchors = NULL;
			a->body_anchor_candidates = NULL;
			a->body_anchor_ring = NULL;
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		a->body_anchor_ring_count = R;
	}
	a->body_anchor_influence_count = Ka;
	a->body_point_count = P;
	a->body_anchor_candidate_count = C;
	int fast_ready = P >= N;
	for ( uint32_t v = 0; fast_ready && a->body_anchor_candidates != NULL && v < N; ++v )
	{
		uint16_t first = a->body_anchor_candidates[(size_t)v * C];
		fast_ready = first == v || first == PLEAT_NO_CONTACT_CANDIDATE;
	}
	a->body_contact_fast_ready = fast_ready;
	return PLEAT_RESULT_OK;
}

static plResult plParseContent( const uint8_t* data, const plSectionTable* table, uint32_t flags, plAssetData* a )
{
	const uint8_t* conf = (const uint8_t*)plRequire( data, table, "CONF", PLEAT_DTYPE_U8, 1, PLEAT_CONF_SIZE, 1, 1 );
	if ( conf == NULL )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	a->vertex_count = plReadU32( conf + 0 );
	a->face_count = plReadU32( conf + 4 );
	a->joint_count = plReadU32( conf + 8 );
	a->input_joint_count = plReadU32( conf + 12 );
	a->influence_count = plReadU32( conf + 16 );
	a->beta_count = plReadU32( conf + 20 );
	a->latent_count = plReadU32( conf + 24 );
	a->blend_count = plReadU32( conf + 28 );
	a->lp_layer_count = plReadU32( conf + 32 );
	a->dec_layer_count = plReadU32( conf + 36 );
	a->lp_activation = plReadU32( conf + 40 );
	a->dec_activation = plReadU32( conf + 44 );
	a->input_count = plReadU32( conf + 48 );
	a->dt_min_s = plReadF32( conf + 52 );
	a->dt_max_s = plReadF32( conf + 56 );
	a->beta_min = plReadF32( conf + 60 );
	a->beta_max = plReadF32( conf + 64 );
	for ( int i = 0; i < 4; ++i )
	{
		a->material_min[i] = plReadF32( conf + 68 + 4 * i );
		a->material_max[i] = plReadF32( conf + 84 + 4 * i );
		a->material_default[i] = plReadF32( conf + 100 + 4 * i );
	}
	a->train_fps = plReadF32( conf + 116 );
	a->weights_fp16 = ( flags & 1u ) != 0;

	uint32_t N = a->vertex_count, F = a->face_count, J = a->joint_count, Jin = a->input_joint_count;
	uint32_t K = a->influence_count, B = a->beta_count, L = a->latent_count, D = a->blend_count;
	if ( N == 0 || N > ( 1u << 24 ) || F == 0 || F > ( 1u << 25 ) || J == 0 || J > PLEAT_MAX_JOINTS || Jin >= J ||
		 K < 1 || K > PLEAT_MAX_INFLUENCES || B > PLEAT_MAX_BETAS || L == 0 || L > 65536 || D == 0 || D > 65536 ||
		 a->lp_layer_count < 1 || a->lp_layer_count > PLEAT_MAX_LAYERS || a->dec_layer_count < 1 ||
		 a->dec_layer_count > PLEAT_MAX_LAYERS || a->lp_activation < 1 || a->lp_activation > 2 ||
		 a->dec_activation < 1 || a->dec_activation > 2 ||
		 (uint64_t)a->input_count != plInputCountFormula( L, Jin, B ) )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	// Written this way so NaN fails every comparison.
	if ( !( a->dt_min_s > 0.0f && a->dt_min_s <= a->dt_max_s && a->dt_max_s <= 1.0f ) ||
		 !( a->beta_min <= a->beta_max ) || !isfinite( a->beta_min ) || !isfinite( a->beta_max ) ||
		 !isfinite( a->train_fps ) )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	for ( int i = 0; i < 4; ++i )
	{
		if ( !isfinite( a->material_min[i] ) || !isfinite( a->material_max[i] ) ||
			 !( a->material_min[i] < a->material_max[i] ) || !( a->material_default[i] >= a->material_min[i] ) ||
			 !( a->material_default[i] <= a->material_max[i] ) )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
	}

	const plSection* name = plFindSection( table, "NAME" );
	if ( name == NULL || name->dtype != PLEAT_DTYPE_U8 || name->rank != 1 || name->dims[0] > 64 )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	memcpy( a->name, data + name->offset, name->dims[0] );
	a->name[name->dims[0]] = 0;
	if ( memchr( a->name, 0, name->dims[0] ) != NULL )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	const plSection* meta = plFindSection( table, "META" );
	if ( meta != NULL )
	{
		if ( meta->dtype != PLEAT_DTYPE_U8 || meta->rank != 1 )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		a->meta = (const char*)( data + meta->offset );
		a->meta_size = meta->size;
	}

	a->joint_names = (const char*)plRequire( data, table, "JNAM", PLEAT_DTYPE_U8, 2, J, PLEAT_JOINT_NAME_SIZE, 1 );
	a->parents = (const int32_t*)plRequire( data, table, "JPAR", PLEAT_DTYPE_I32, 1, J, 1, 1 );
	a->joint_template = (const float*)plRequire( data, table, "JTPL", PLEAT_DTYPE_F32, 2, J, 3, 1 );
	a->joint_shapedirs = (const float*)plRequire( data, table, "JSHP", PLEAT_DTYPE_F32, 3, B, J, 3 );
	a->input_joints = (const uint32_t*)plRequire( data, table, "JINP", PLEAT_DTYPE_U32, 1, Jin, 1, 1 );
	a->template_positions = (const float*)plRequire( data, table, "TMPL", PLEAT_DTYPE_F32, 2, N, 3, 1 );
	a->shape_blend = (const float*)plRequire( data, table, "SHPB", PLEAT_DTYPE_F32, 3, B, N, 3 );
	a->faces = (const uint32_t*)plRequire( data, table, "FACE", PLEAT_DTYPE_U32, 2, F, 3, 1 );
	a->adjacency_offsets = (const uint32_t*)plRequire( data, table, "NADO", PLEAT_DTYPE_U32, 1, N + 1, 1, 1 );
	a->adjacency_faces = (const uint32_t*)plRequire( data, table, "NADF", PLEAT_DTYPE_U32, 1, 3 * F, 1, 1 );
	a->skin_indices = (const uint16_t*)plRequire( data, table, "SKNI", PLEAT_DTYPE_U16, 2, N, K, 1 );
	a->skin_weights = (const float*)plRequire( data, table, "SKNW", PLEAT_DTYPE_F32, 2, N, K, 1 );
	a->x_mean = (const float*)plRequire( data, table, "XMEA", PLEAT_DTYPE_F32, 1, a->input_count, 1, 1 );
	a->x_std = (const float*)plRequire( data, table, "XSTD", PLEAT_DTYPE_F32, 1, a->input_count, 1, 1 );
	a->z_mean = (const float*)plRequire( data, table, "ZMEA", PLEAT_DTYPE_F32, 1, L, 1, 1 );
	a->z_std = (const float*)plRequire( data, table, "ZSTD", PLEAT_DTYPE_F32, 1, L, 1, 1 );
	a->z_min = (const float*)plRequire( data, table, "ZMIN", PLEAT_DTYPE_F32, 1, L, 1, 1 );
	a->z_max = (const float*)plRequire( data, table, "ZMAX", PLEAT_DTYPE_F32, 1, L, 1, 1 );
	// JSHP and SHPB have B = 0 rows for a shape-less asset: a 0-dim section is allowed and optional then.
	if ( B == 0 )
	{
		static const float no_floats[1] = { 0.0f };
		if ( a->joint_shapedirs == NULL )
		{
			a->joint_shapedirs = no_floats;
		}
		if ( a->shape_blend == NULL )
		{
			a->shape_blend = no_floats;
		}
	}
	if ( a->joint_names == NULL || a->parents == NULL || a->joint_template == NULL || a->joint_shapedirs == NULL ||
		 a->input_joints == NULL || a->template_positions == NULL || a->shape_blend == NULL || a->faces == NULL ||
		 a->adjacency_offsets == NULL || a->adjacency_faces == NULL || a->skin_indices == NULL ||
		 a->skin_weights == NULL || a->x_mean == NULL || a->x_std == NULL || a->z_mean == NULL || a->z_std == NULL ||
		 a->z_min == NULL || a->z_max == NULL )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}

	// Joints: names NUL-terminated, parents before children, root only at 0.
	for ( uint32_t j = 0; j < J; ++j )
	{
		if ( memchr( a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE, 0, PLEAT_JOINT_NAME_SIZE ) == NULL )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		int32_t p = a->parents[j];
		if ( j == 0 ? p != -1 : ( p < 0 || p >= (int32_t)j ) )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
	}
	for ( uint32_t i = 0; i < Jin; ++i )
	{
		uint32_t k = a->input_joints[i];
		if ( k == 0 || k >= J || ( i > 0 && k <= a->input_joints[i - 1] ) )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
	}
	if ( !plAllFiniteFloats( a->joint_template, (uint64_t)J * 3 ) ||
		 !plAllFiniteFloats( a->joint_shapedirs, (uint64_t)B * J * 3 ) ||
		 !plAllFiniteFloats( a->template_positions, (uint64_t)N * 3 ) ||
		 !plAllFiniteFloats( a->shape_blend, (uint64_t)B * N * 3 ) || !plAllFiniteFloats( a->x_mean, a->input_count ) ||
		 !plAllFiniteFloats( a->x_std, a->input_count ) || !plAllFiniteFloats( a->z_mean, L ) || !plAllFiniteFloats( a->z_std, L ) ||
		 !plAllFiniteFloats( a->z_min, L ) || !plAllFiniteFloats( a->z_max, L ) )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	for ( uint32_t i = 0; i < a->input_count; ++i )
	{
		if ( !( a->x_std[i] > 0.0f ) )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
	}
	for ( uint32_t i = 0; i < L; ++i )
	{
		if ( !( a->z_std[i] > 0.0f ) || !( a->z_min[i] <= a->z_max[i] ) )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
	}
	// Mesh: face indices in range; CSR adjacency consistent; skinning.
	for ( uint64_t i = 0; i < (uint64_t)F * 3; ++i )
	{
		if ( a->faces[i] >= N )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
	}
	if ( a->adjacency_offsets[0] != 0 || a->adjacency_offsets[N] != 3 * F )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	for ( uint32_t v = 0; v < N; ++v )
	{
		uint32_t begin = a->adjacency_offsets[v], end = a->adjacency_offsets[v + 1];
		if ( end < begin || end > 3 * F )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		for ( uint32_t e = begin; e < end; ++e )
		{
			uint32_t f = a->adjacency_faces[e];
			if ( f >= F || ( e > begin && f <= a->adjacency_faces[e - 1] ) )
			{
				return PLEAT_RESULT_INVALID_ASSET_DATA;
			}
			const uint32_t* tri = a->faces + (size_t)f * 3;
			if ( tri[0] != v && tri[1] != v && tri[2] != v )
			{
				return PLEAT_RESULT_INVALID_ASSET_DATA;
			}
		}
	}
	if ( !plSkinRowsValid( a->skin_indices, a->skin_weights, N, K, J ) )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	// Networks and blend shapes.
	plResult r = plParseLayers( data, table, flags, 'L', 'P', 'P', a->lp_layer_count, a->input_count, L, a->lp );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	r = plParseLayers( data, table, flags, 'D', 'C', 'C', a->dec_layer_count, L, D, a->dec );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	a->blend_shapes = plRequireWeights( data, table, "BLND", flags, 3, D, N, 3, &a->blend_shapes_fp16 );
	if ( a->blend_shapes == NULL )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	const plSection* pins = plFindSection( table, "PINS" );
	if ( pins != NULL )
	{
		if ( pins->dtype != PLEAT_DTYPE_U32 || pins->rank != 1 )
		{
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
		a->pinned = (const uint32_t*)( data + pins->offset );
		a->pinned_count = pins->dims[0];
		for ( uint32_t i = 0; i < a->pinned_count; ++i )
		{
			if ( a->pinned[i] >= N )
			{
				return PLEAT_RESULT_INVALID_ASSET_DATA;
			}
		}
	}
	r = plParseBodyContact( data, table, a );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	const plSection* oxlp = plFindSection( table, "OXLP" );
	const plSection* oxdc = plFindSection( table, "OXDC" );
	if ( ( oxlp != NULL && ( oxlp->dtype != PLEAT_DTYPE_U8 || oxlp->size == 0 ) ) ||
		 ( oxdc != NULL && ( oxdc->dtype != PLEAT_DTYPE_U8 || oxdc->size == 0 ) ) )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	if ( oxlp != NULL )
	{
		a->onnx_lp = data + oxlp->offset;
		a->onnx_lp_size = oxlp->size;
	}
	if ( oxdc != NULL )
	{
		a->onnx_dec = data + oxdc->offset;
		a->onnx_dec_size = oxdc->size;
	}
	// Checked here, whatever backend an instance will use: an asset whose model reaches outside it is not one asset
	// (onnx_model.c), and loading it is where an engine learns that.
	const plSection* models[2] = { oxlp, oxdc };
	for ( int m = 0; m < 2; ++m )
	{
		plOnnxFinding finding =
			models[m] != NULL ? plOnnxModel_Check( data + models[m]->offset, models[m]->size ) : PLEAT_ONNX_SELF_CONTAINED;
		if ( finding != PLEAT_ONNX_SELF_CONTAINED )
		{
			a->rejected_item =
				finding == PLEAT_ONNX_MALFORMED ? PLEAT_LOG_ASSET_BAD_CONTENT : PLEAT_LOG_ASSET_ONNX_REACHES_OUTSIDE;
			snprintf( a->rejected_detail, sizeof( a->rejected_detail ), "%s: %s", m == 0 ? "OXLP" : "OXDC",
					  plOnnxFinding_Describe( finding ) );
			return PLEAT_RESULT_INVALID_ASSET_DATA;
		}
	}
	return PLEAT_RESULT_OK;
}

plResult plAssetData_Parse( const uint8_t* data, size_t size, int skip_checksum, plAssetData* out )
{
	if ( data == NULL || out == NULL || ( (uintptr_t)data & 63u ) != 0 )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	memset( out, 0, sizeof( *out ) );
	// The section table is 12 KiB at most; it lives on the stack only for the parse.
	plSectionTable table;
	uint32_t flags = 0;
	plResult r = plParseHeader( data, size, skip_checksum, &table, &flags );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	r = plParseContent( data, &table, flags, out );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	out->block = data;
	out->size = size;
	return PLEAT_RESULT_OK;
}

// ---- public API ----

plAssetDef plDefaultAssetDef( void )
{
	plAssetDef def = { .internal_cookie = PLEAT_DEF_COOKIE };
	return def;
}

#if !defined( _WIN32 )
// What a path names when it is not a regular file, for the log.
static const char* plFileKind( mode_t mode )
{
	return S_ISDIR( mode ) ? "a directory" : S_ISFIFO( mode ) ? "a FIFO" : S_ISSOCK( mode ) ? "a socket" :
		   S_ISCHR( mode ) || S_ISBLK( mode ) ? "a device" : "not a regular file";
}
#endif

// Opens an asset file for reading, and its size, only if it is a regular file; IO_ERROR for anything else, with the
// reason in detail. Only a regular file's size is something to allocate for (fopen succeeds on a directory on POSIX
// systems and fseek/ftell then report LONG_MAX, which once became a 2^63-byte request), and only a regular file can be
// opened without waiting: open() on a FIFO blocks until a writer comes, for ever if none does. So the path is checked
// with stat before anything is opened, and opened with O_NONBLOCK and checked again with fstat, in case something
// else took the path in between.
static plResult plOpenRegularFile( const char* path, FILE** out_file, uint64_t* out_size, char* detail,
								   size_t detail_size )
{
#if defined( _WIN32 )
	FILE* file = fopen( path, "rb" );
	if ( file == NULL )
	{
		snprintf( detail, detail_size, "cannot be opened" );
		return PLEAT_RESULT_IO_ERROR;
	}
	struct _stat64 info;
	if ( _fstat64( _fileno( file ), &info ) != 0 || ( info.st_mode & _S_IFMT ) != _S_IFREG || info.st_size < 0 )
	{
		snprintf( detail, detail_size, "not a regular file" );
		fclose( file );
		return PLEAT_RESULT_IO_ERROR;
	}
#else
	struct stat info;
	if ( stat( path, &info ) != 0 )
	{
		snprintf( detail, detail_size, "cannot be opened (no such file, or no permission)" );
		return PLEAT_RESULT_IO_ERROR;
	}
	if ( !S_ISREG( info.st_mode ) )
	{
		snprintf( detail, detail_size, "not a regular file (%s)", plFileKind( info.st_mode ) );
		return PLEAT_RESULT_IO_ERROR;
	}
	int fd = open( path, O_RDONLY | O_NONBLOCK | O_CLOEXEC );
	if ( fd < 0 )
	{
		snprintf( detail, detail_size, "cannot be opened" );
		return PLEAT_RESULT_IO_ERROR;
	}
	FILE* file = NULL;
	int flags = fcntl( fd, F_GETFL );
	if ( fstat( fd, &info ) != 0 || info.st_size < 0 )
	{
		snprintf( detail, detail_size, "cannot be read" );
	}
	else if ( !S_ISREG( info.st_mode ) )
	{
		snprintf( detail, detail_size, "not a regular file (%s)", plFileKind( info.st_mode ) );
	}
	// Reads of a regular file never wait anyway; the flag goes so that stdio sees an ordinary descriptor.
	else if ( flags == -1 || fcntl( fd, F_SETFL, flags & ~O_NONBLOCK ) == -1 ||
			  ( file = fdopen( fd, "rb" ) ) == NULL )
	{
		snprintf( detail, detail_size, "cannot be opened" );
	}
	if ( file == NULL )
	{
		close( fd );
		return PLEAT_RESULT_IO_ERROR;
	}
#endif
	*out_file = file;
	*out_size = (uint64_t)info.st_size;
	return PLEAT_RESULT_OK;
}

// Reads a whole asset file into a 64-byte aligned block; detail (for the log) says why it could not.
static plResult plReadFile( plContextData* ctx, const char* path, void** out_block, size_t* out_size, char* detail,
							size_t detail_size )
{
	FILE* file = NULL;
	uint64_t length = 0;
	plResult r = plOpenRegularFile( path, &file, &length, detail, detail_size );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	if ( length == 0 )
	{
		r = PLEAT_RESULT_TRUNCATED;
	}
	else if ( (uint64_t)(size_t)length != length )
	{
		r = PLEAT_RESULT_OUT_OF_MEMORY; // a 32-bit process cannot hold it
	}
	void* block = NULL;
	if ( r == PLEAT_RESULT_OK )
	{
		block = plAlloc( &ctx->allocator, (size_t)length, 64 );
		if ( block == NULL )
		{
			r = PLEAT_RESULT_OUT_OF_MEMORY;
		}
		else if ( fread( block, 1, (size_t)length, file ) != (size_t)length )
		{
			r = PLEAT_RESULT_IO_ERROR; // shorter than it was a moment ago, or a read error
			snprintf( detail, detail_size, "read failed or the file shrank" );
		}
	}
	fclose( file );
	if ( r != PLEAT_RESULT_OK )
	{
		plFree( &ctx->allocator, block, block != NULL ? (size_t)length : 0 );
		return r;
	}
	*out_block = block;
	*out_size = (size_t)length;
	return PLEAT_RESULT_OK;
}

static plLogItem plLogItemForLoadResult( plResult r )
{
	switch ( r )
	{
		case PLEAT_RESULT_IO_ERROR:
			return PLEAT_LOG_ASSET_IO_ERROR;
		case PLEAT_RESULT_CHECKSUM_MISMATCH:
			return PLEAT_LOG_ASSET_CHECKSUM_MISMATCH;
		case PLEAT_RESULT_MALFORMED_ASSET:
			return PLEAT_LOG_ASSET_BAD_SECTION_TABLE;
		case PLEAT_RESULT_INVALID_ASSET_DATA:
			return PLEAT_LOG_ASSET_BAD_CONTENT;
		case PLEAT_RESULT_OUT_OF_MEMORY:
			return PLEAT_LOG_OUT_OF_MEMORY;
		default:
			return PLEAT_LOG_ASSET_BAD_HEADER;
	}
}

// The next `bytes` of a derived block (NULL for none), each part starting on a 64-byte line.
static void* plTakeDerived( uint8_t** cursor, size_t bytes )
{
	if ( bytes == 0 )
	{
		return NULL;
	}
	void* part = *cursor;
	*cursor += plAlign64( bytes );
	return part;
}

// What the load derives for the kernels, in one block: the single step's packed copies of the networks' block layers
// (kernels.h plLayer.packed), the body's rings in lanes for the AVX2 ring normals (plRingLanes), the contact
// candidates as posed rows' offsets for the AVX2 push (plContactRowOffsets) and the garment's and body points' skin
// indices as column-block offsets for the AVX2 skinning and posing (plSkinColumnOffsets).
static plResult plDeriveKernelData( plContextData* ctx, plAssetData* asset )
{
	uint32_t layer_count = asset->lp_layer_count + asset->dec_layer_count;
	uint32_t C = asset->body_anchor_candidates != NULL ? asset->body_anchor_candidate_count : 1;
	size_t N = asset->vertex_count, P = asset->body_point_count;
	size_t ring_bytes = asset->body_anchor_ring != NULL
							? plRingLanesCount( asset->body_point_count, asset->body_anchor_ring_count ) * sizeof( int32_t )
							: 0;
	size_t row_bytes = P > 0 ? plContactRowOffsetsCount( asset->vertex_count, C ) * sizeof( uint32_t ) : 0;
	size_t skin_count = N * asset->influence_count, body_count = P * asset->body_anchor_influence_count;
	size_t total = plAlign64( ring_bytes ) + plAlign64( row_bytes ) + plAlign64( skin_count * sizeof( uint32_t ) ) +
				   plAlign64( body_count * sizeof( uint32_t ) );
	for ( uint32_t i = 0; i < layer_count; ++i )
	{
		const plLayer* l = i < asset->lp_layer_count ? &asset->lp[i] : &asset->dec[i - asset->lp_layer_count];
		total += plAlign64( plPackedLayerBytes( l ) );
	}
	if ( total == 0 )
	{
		return PLEAT_RESULT_OK;
	}
	uint8_t* cursor = (uint8_t*)plAlloc( &ctx->allocator, total, 64 );
	if ( cursor == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	asset->derived_block = cursor;
	asset->derived_size = total;
	for ( uint32_t i = 0; i < layer_count; ++i )
	{
		plLayer* l = i < asset->lp_layer_count ? &asset->lp[i] : &asset->dec[i - asset->lp_layer_count];
		void* copy = plTakeDerived( &cursor, plPackedLayerBytes( l ) );
		if ( copy != NULL )
		{
			plPackLayer( l, copy );
		}
	}
	int32_t* ring_lanes = (int32_t*)plTakeDerived( &cursor, ring_bytes );
	if ( ring_lanes != NULL )
	{
		plRingLanes( ring_lanes, asset->body_anchor_ring, asset->body_anchor_ring_count, asset->body_point_count );
		asset->body_anchor_ring_lanes = ring_lanes;
	}
	uint32_t* row_offsets = (uint32_t*)plTakeDerived( &cursor, row_bytes );
	if ( row_offsets != NULL )
	{
		plContactRowOffsets( row_offsets, asset->body_anchor_candidates, C, asset->vertex_count,
							 asset->body_point_count );
		asset->body_contact_row_offsets = row_offsets;
	}
	uint32_t* skin_offsets = (uint32_t*)plTakeDerived( &cursor, skin_count * sizeof( uint32_t ) );
	if ( skin_offsets != NULL )
	{
		plSkinColumnOffsets( skin_offsets, asset->skin_indices, skin_count, asset->joint_count );
		asset->skin_column_offsets = skin_offsets;
	}
	uint32_t* body_offsets = (uint32_t*)plTakeDerived( &cursor, body_count * sizeof( uint32_t ) );
	if ( body_offsets != NULL )
	{
		plSkinColumnOffsets( body_offsets, asset->body_anchor_skin_indices, body_count, asset->joint_count );
		asset->body_anchor_column_offsets = body_offsets;
	}
	return PLEAT_RESULT_OK;
}

// Floats of a context scratch block plStepInstances needs for the asset with the context's batched kernels: the
// transposed networks (the lanes MLP), the lane groups' normals and their full body contact (0 for the scalar set,
// which has no lanes form). Worked out at load, so that instance creation sizes the context's pool from it.
static size_t plBatchScratchFloats( const plContextData* ctx, const plAssetData* a )
{
	const plBatchKernels* kernels = ctx->kernels.batch;
	size_t floats = 0;
	if ( kernels == NULL )
	{
		return 0;
	}
	if ( kernels->geometry_lanes > 1 )
	{
		floats = plNormalsBatchScratchFloats( a->vertex_count, kernels->geometry_lanes );
		size_t contact = kernels->body_contact_batch != NULL ? plBodyContactBatchScratchFloats( a->body_point_count )
															 : 0;
		floats = contact > floats ? contact : floats;
	}
	if ( kernels->mat_mat_lanes != NULL )
	{
		size_t lp = plMlpBatchLanesFloats( a->lp, a->lp_layer_count, PLEAT_BATCH_MAX );
		size_t dec = plMlpBatchLanesFloats( a->dec, a->dec_layer_count, PLEAT_BATCH_MAX );
		floats = lp > floats ? lp : floats;
		floats = dec > floats ? dec : floats;
	}
	return floats;
}

// The asset table's destroy callback (plDestroyObjectFn), also what plDestroyAsset frees with.
static void plAssetData_Destroy( plContextData* ctx, void* object )
{
	plAssetData* asset = (plAssetData*)object;
	plFree( &ctx->allocator, asset->derived_block, asset->derived_size );
	plFree( &ctx->allocator, asset->owned_block, asset->owned_size );
	plFree( &ctx->allocator, asset, sizeof( plAssetData ) );
}

plResult plLoadAsset( plContext context, const plAssetDef* def, plAsset* out_asset )
{
	plContextData* ctx;
	plResult r = plBeginCreate( context, def, out_asset, sizeof( *out_asset ), &ctx );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	if ( def->internal_cookie != PLEAT_DEF_COOKIE || ( def->path == NULL ) == ( def->data == NULL ) ||
		 ( def->data != NULL && def->size == 0 ) ||
		 ( def->flags & ~( PLEAT_ASSET_FLAG_USE_IN_PLACE | PLEAT_ASSET_FLAG_SKIP_CHECKSUM ) ) != 0 )
	{
		return PLEAT_RESULT_INVALID_DEF;
	}
	plAssetData* asset = (plAssetData*)plAllocZeroed( &ctx->allocator, sizeof( plAssetData ), 64 );
	if ( asset == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	void* owned = NULL;
	size_t owned_size = 0;
	const uint8_t* block = NULL;
	size_t size = 0;
	if ( def->path != NULL )
	{
		r = plReadFile( ctx, def->path, &owned, &owned_size, asset->rejected_detail, sizeof( asset->rejected_detail ) );
		block = (const uint8_t*)owned;
		size = owned_size;
	}
	else if ( ( def->flags & PLEAT_ASSET_FLAG_USE_IN_PLACE ) != 0 && ( (uintptr_t)def->data & 63u ) == 0 )
	{
		block = (const uint8_t*)def->data;
		size = def->size;
	}
	else
	{
		owned = plAlloc( &ctx->allocator, def->size, 64 );
		if ( owned == NULL )
		{
			r = PLEAT_RESULT_OUT_OF_MEMORY;
		}
		else
		{
			memcpy( owned, def->data, def->size );
			owned_size = def->size;
			block = (const uint8_t*)owned;
			size = def->size;
			if ( ( def->flags & PLEAT_ASSET_FLAG_USE_IN_PLACE ) != 0 )
			{
				plLog( ctx, PLEAT_LOG_LEVEL_WARNING, PLEAT_LOG_ASSET_COPIED, "buffer not 64-byte aligned" );
			}
		}
	}
	if ( r == PLEAT_RESULT_OK )
	{
		r = plAssetData_Parse( block, size, ( def->flags & PLEAT_ASSET_FLAG_SKIP_CHECKSUM ) != 0, asset );
	}
	if ( r == PLEAT_RESULT_OK )
	{
		r = plDeriveKernelData( ctx, asset );
		asset->batch_scratch_floats = plBatchScratchFloats( ctx, asset );
	}
	if ( r == PLEAT_RESULT_OK )
	{
		r = plSlotTable_Insert( ctx, &ctx->assets, asset, plAssetData_Destroy, &out_asset->index1,
								&out_asset->generation );
	}
	if ( r != PLEAT_RESULT_OK )
	{
		plLogItem item = asset->rejected_item != PLEAT_LOG_NONE ? asset->rejected_item : plLogItemForLoadResult( r );
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, item, "%s (%s)%s%s", plResultString( r ),
			   def->path != NULL ? def->path : "memory", asset->rejected_detail[0] != '\0' ? ": " : "",
			   asset->rejected_detail );
		plFree( &ctx->allocator, asset->derived_block, asset->derived_size );
		plFree( &ctx->allocator, owned, owned_size );
		plFree( &ctx->allocator, asset, sizeof( plAssetData ) );
		return r;
	}
	asset->owned_block = owned;
	asset->owned_size = owned_size;
	out_asset->context = ctx->handle;
	plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_ASSET_LOADED, "'%s': N=%u F=%u J=%u L=%u D=%u", asset->name,
		   asset->vertex_count, asset->face_count, asset->joint_count, asset->latent_count, asset->blend_count );
	return PLEAT_RESULT_OK;
}

plAssetData* plGetAssetData( plAsset asset )
{
	plContextData* ctx = plGetContext( asset.context ); // the context generation too: its slot may have a new context
	return ctx != NULL ? (plAssetData*)plSlotTable_Get( &ctx->assets, asset.index1, asset.generation ) : NULL;
}

int plAsset_IsValid( plAsset asset )
{
	return plGetAssetData( asset ) != NULL;
}

plResult plDestroyAsset( plAsset handle )
{
	plContextData* ctx = plGetContext( handle.context );
	const plAssetData* asset = plGetAssetData( handle );
	if ( asset != NULL && asset->instance_count != 0 )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_ASSET_IN_USE, "%u instances", asset->instance_count );
		return PLEAT_RESULT_ASSET_IN_USE;
	}
	return asset != NULL ? plSlotTable_Destroy( ctx, &ctx->assets, handle.index1, handle.generation )
						 : PLEAT_RESULT_INVALID_HANDLE;
}

plResult plAsset_GetInfo( plAsset handle, plAssetInfo* out_info )
{
	const plAssetData* a = plGetAssetData( handle );
	plResult r = plCheckArgumentsThenHandle( out_info != NULL, a );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	memset( out_info, 0, sizeof( *out_info ) );
	out_info->vertex_count = a->vertex_count;
	out_info->face_count = a->face_count;
	out_info->joint_count = a->joint_count;
	out_info->input_joint_count = a->input_joint_count;
	out_info->influence_count = a->influence_count;
	out_info->beta_count = a->beta_count;
	out_info->latent_count = a->latent_count;
	out_info->blend_count = a->blend_count;
	out_info->input_count = a->input_count;
	out_info->lp_layer_count = a->lp_layer_count;
	out_info->dec_layer_count = a->dec_layer_count;
	out_info->weights_fp16 = a->weights_fp16;
	out_info->dt_min_s = a->dt_min_s;
	out_info->dt_max_s = a->dt_max_s;
	out_info->beta_min = a->beta_min;
	out_info->beta_max = a->beta_max;
	memcpy( out_info->material_min, a->material_min, sizeof( a->material_min ) );
	memcpy( out_info->material_max, a->material_max, sizeof( a->material_max ) );
	memcpy( out_info->material_default, a->material_default, sizeof( a->material_default ) );
	out_info->train_fps = a->train_fps;
	memcpy( out_info->name, a->name, sizeof( a->name ) );
	out_info->meta_json = a->meta;
	out_info->meta_json_size = a->meta_size;
	out_info->has_onnx_lp = a->onnx_lp != NULL;
	out_info->has_onnx_decoder = a->onnx_dec != NULL;
	out_info->pinned_count = a->pinned_count;
	out_info->has_body_contact = a->body_anchors != NULL;
	return PLEAT_RESULT_OK;
}

plResult plAsset_GetJointName( plAsset handle, uint32_t joint_index, const char** out_name )
{
	const plAssetData* a = plGetAssetData( handle );
	plResult r = plCheckArgumentsThenHandle( out_name != NULL, a );
	if ( r == PLEAT_RESULT_OK && joint_index >= a->joint_count )
	{
		r = PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( out_name != NULL )
	{
		*out_name = r == PLEAT_RESULT_OK ? a->joint_names + (size_t)joint_index * PLEAT_JOINT_NAME_SIZE : NULL;
	}
	return r;
}

// The two getters that lend an asset array with its row count: the faces (out_faces) or the template positions
// (out_positions, the other one NULL). Both outputs are required; they are null and 0 unless the call succeeds.
static plResult plLendAssetArray( plAsset handle, const uint32_t** out_faces, const float** out_positions,
								  uint32_t* out_count )
{
	if ( ( out_faces == NULL && out_positions == NULL ) || out_count == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	const plAssetData* a = plGetAssetData( handle );
	if ( out_faces != NULL )
	{
		*out_faces = a != NULL ? a->faces : NULL;
		*out_count = a != NULL ? a->face_count : 0;
	}
	else
	{
		*out_positions = a != NULL ? a->template_positions : NULL;
		*out_count = a != NULL ? a->vertex_count : 0;
	}
	return a != NULL ? PLEAT_RESULT_OK : PLEAT_RESULT_INVALID_HANDLE;
}

plResult plAsset_GetFaces( plAsset handle, const uint32_t** out_faces, uint32_t* out_face_count )
{
	return plLendAssetArray( handle, out_faces, NULL, out_face_count );
}

plResult plAsset_GetTemplatePositions( plAsset handle, const float** out_positions, uint32_t* out_vertex_count )
{
	return plLendAssetArray( handle, NULL, out_positions, out_vertex_count );
}

plResult plAsset_FindJoint( plAsset handle, const char* name, int32_t* out_joint_index )
{
	const plAssetData* a = plGetAssetData( handle );
	plResult r = plCheckArgumentsThenHandle( name != NULL && out_joint_index != NULL, a );
	if ( r != PLEAT_RESULT_INVALID_ARGUMENT )
	{
		*out_joint_index = -1;
	}
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		if ( strncmp( a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE, name, PLEAT_JOINT_NAME_SIZE ) == 0 &&
			 strlen( name ) < PLEAT_JOINT_NAME_SIZE )
		{
			*out_joint_index = (int32_t)j;
			return PLEAT_RESULT_OK;
		}
	}
	return PLEAT_RESULT_NOT_FOUND;
}
