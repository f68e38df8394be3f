// The asset loader: each kind of broken file gets its documented code (truncated, flipped bytes, wrong magic, legacy
// and unsupported versions, broken structure, broken content); a valid file loads from memory (copied or in place)
// and from disk; random corruption never crashes it (run under PLEAT_SANITIZE to check it never reads out of bounds).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>

#include "asset.h"
#include "test_common.h"

typedef struct plLoaderFixture
{
	plTestAsset* model;
	uint8_t* bytes;
	size_t size;
	plContext context;
} plLoaderFixture;

static int plLoaderSetup( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)calloc( 1, sizeof( plLoaderFixture ) );
	plTestAssetParams p = plTestAsset_DefaultParams();
	f->model = plTestAsset_Create( &p );
	if ( f->model == NULL || !plTestAsset_AddBodyAnchors( f->model, 0.002f ) ) // the optional 1.2 block, checked too
	{
		return -1;
	}
	f->bytes = plTestAsset_Write( f->model, &f->size );
	plContextDef def = plDefaultContextDef();
	if ( plCreateContext( &def, &f->context ) != PLEAT_RESULT_OK )
	{
		return -1;
	}
	*state = f;
	return 0;
}

static int plLoaderTeardown( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	uint64_t live = 1;
	plContext_GetLiveBytes( f->context, &live );
	plDestroyContext( f->context );
	plTestAsset_FreeBytes( f->bytes );
	plTestAsset_Destroy( f->model );
	free( f );
	return live == 0 ? 0 : -1; // every load, failed or destroyed, gave its memory back (pleat.h: exactly 0)
}

// Loads a modified copy of the valid bytes (edit may be NULL); the copy is 64-byte aligned.
static plResult plLoadEdited( plLoaderFixture* f, size_t size, void ( *edit )( uint8_t*, size_t, void* ), void* arg,
							  int fix_checksum, uint32_t flags )
{
	uint8_t* copy = (uint8_t*)aligned_alloc( 64, ( f->size + 63 ) & ~(size_t)63 );
	memcpy( copy, f->bytes, f->size );
	if ( edit != NULL )
	{
		edit( copy, f->size, arg );
	}
	if ( fix_checksum )
	{
		plTestAsset_FixChecksum( copy, size );
	}
	plAssetDef def = plDefaultAssetDef();
	def.data = copy;
	def.size = size;
	def.flags = flags;
	plAsset asset;
	plResult r = plLoadAsset( f->context, &def, &asset );
	if ( r == PLEAT_RESULT_OK )
	{
		assert_true( plAsset_IsValid( asset ) );
		assert_int_equal( plDestroyAsset( asset ), PLEAT_RESULT_OK );
	}
	else
	{
		assert_false( plAsset_IsValid( asset ) );
	}
	free( copy );
	return r;
}

static void plPutU32At( uint8_t* b, size_t offset, uint32_t v )
{
	memcpy( b + offset, &v, 4 );
}

static void plPutU64At( uint8_t* b, size_t offset, uint64_t v )
{
	memcpy( b + offset, &v, 8 );
}

// The loader's CRC-32 is zlib.crc32: the standard check value, and the bit-by-bit definition on every length and split
// (the sliced loop, its byte tail and chaining across calls).
static uint32_t plCrc32Bitwise( uint32_t crc, const uint8_t* data, size_t size )
{
	crc = ~crc;
	for ( size_t i = 0; i < size; ++i )
	{
		crc ^= data[i];
		for ( int k = 0; k < 8; ++k )
		{
			crc = ( crc & 1u ) ? 0xEDB88320u ^ ( crc >> 1 ) : crc >> 1;
		}
	}
	return ~crc;
}

static void test_crc32_matches_zlib_definition( void** state )
{
	(void)state;
	assert_int_equal( plCrc32( 0, (const uint8_t*)"123456789", 9 ), 0xCBF43926u );
	assert_int_equal( plCrc32( 0, NULL, 0 ), 0u );
	uint8_t bytes[301];
	uint32_t seed = 12345u;
	for ( size_t i = 0; i < sizeof( bytes ); ++i )
	{
		seed = seed * 1664525u + 1013904223u;
		bytes[i] = (uint8_t)( seed >> 24 );
	}
	for ( size_t size = 0; size <= sizeof( bytes ); size += 1 + size / 16 )
	{
		uint32_t expected = plCrc32Bitwise( 0, bytes, size );
		assert_int_equal( plCrc32( 0, bytes, size ), expected );
		size_t split = size / 3;
		assert_int_equal( plCrc32( plCrc32( 0, bytes, split ), bytes + split, size - split ), expected );
	}
}

static void test_valid_asset_loads_copied_in_place_and_from_file( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	assert_int_equal( plLoadEdited( f, f->size, NULL, NULL, 0, 0 ), PLEAT_RESULT_OK );
	// In place: the block is not copied, so far fewer bytes are live than the asset's size.
	plAssetDef def = plDefaultAssetDef();
	def.data = f->bytes;
	def.size = f->size;
	def.flags = PLEAT_ASSET_FLAG_USE_IN_PLACE;
	uint64_t before = 0, after = 0;
	plContext_GetLiveBytes( f->context, &before );
	plAsset asset;
	assert_int_equal( plLoadAsset( f->context, &def, &asset ), PLEAT_RESULT_OK );
	plContext_GetLiveBytes( f->context, &after );
	assert_true( after - before < f->size );
	assert_int_equal( plDestroyAsset( asset ), PLEAT_RESULT_OK );
	// Not 64-byte aligned: copied even with the flag, and still loads.
	uint8_t* shifted = (uint8_t*)malloc( f->size + 64 );
	uint8_t* odd = shifted + ( 64 - ( (uintptr_t)shifted & 63u ) ) + 8;
	if ( odd + f->size > shifted + f->size + 64 )
	{
		odd -= 64;
	}
	memcpy( odd, f->bytes, f->size );
	def.data = odd;
	plContext_GetLiveBytes( f->context, &before );
	assert_int_equal( plLoadAsset( f->context, &def, &asset ), PLEAT_RESULT_OK );
	plContext_GetLiveBytes( f->context, &after );
	assert_true( after - before >= f->size );
	assert_int_equal( plDestroyAsset( asset ), PLEAT_RESULT_OK );
	free( shifted );
	// From a file.
	FILE* file = fopen( "test_asset_loader.pleat", "wb" );
	assert_non_null( file );
	assert_int_equal( fwrite( f->bytes, 1, f->size, file ), f->size );
	fclose( file );
	def = plDefaultAssetDef();
	def.path = "test_asset_loader.pleat";
	assert_int_equal( plLoadAsset( f->context, &def, &asset ), PLEAT_RESULT_OK );
	plAssetInfo info;
	assert_int_equal( plAsset_GetInfo( asset, &info ), PLEAT_RESULT_OK );
	assert_int_equal( info.vertex_count, f->model->N );
	assert_int_equal( plDestroyAsset( asset ), PLEAT_RESULT_OK );
	remove( "test_asset_loader.pleat" );
	// Both data and path: an invalid def.
	def.data = f->bytes;
	def.size = f->size;
	assert_int_equal( plLoadAsset( f->context, &def, &asset ), PLEAT_RESULT_INVALID_DEF );
}

static void test_truncated_asset_is_rejected( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	const size_t sizes[] = { 0 + 1, 7, 11, 100, 128, 200, f->size / 2, f->size - 1 };
	for ( size_t i = 0; i < sizeof( sizes ) / sizeof( sizes[0] ); ++i )
	{
		assert_int_equal( plLoadEdited( f, sizes[i], NULL, NULL, 0, 0 ), PLEAT_RESULT_TRUNCATED );
	}
}

static void plFlipByte( uint8_t* b, size_t size, void* arg )
{
	(void)size;
	size_t at = *(size_t*)arg;
	b[at] ^= 0x10u;
}

static void test_flipped_bytes_fail_the_checksum( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	size_t positions[4] = { 50, plTestAsset_SectionOffset( f->bytes, "TMPL" ) + 5,
							plTestAsset_SectionOffset( f->bytes, "BLND" ) + 17, f->size - 40 };
	for ( int i = 0; i < 4; ++i )
	{
		assert_int_equal( plLoadEdited( f, f->size, plFlipByte, &positions[i], 0, 0 ), PLEAT_RESULT_CHECKSUM_MISMATCH );
	}
	// With the checksum skipped, a flipped bit in the blend shapes (still a finite float) loads.
	assert_int_equal( plLoadEdited( f, f->size, plFlipByte, &positions[2], 0, PLEAT_ASSET_FLAG_SKIP_CHECKSUM ),
					  PLEAT_RESULT_OK );
}

static void plSetMagic( uint8_t* b, size_t size, void* arg )
{
	(void)size;
	(void)arg;
	b[0] = 'X';
}

static void plSetVersion( uint8_t* b, size_t size, void* arg )
{
	(void)size;
	uint32_t v = *(uint32_t*)arg;
	b[8] = (uint8_t)( v & 0xFF );
	b[9] = (uint8_t)( v >> 8 );
	b[10] = (uint8_t)( v >> 16 ); // minor
}

static void test_wrong_magic_and_versions_are_rejected( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	assert_int_equal( plLoadEdited( f, f->size, plSetMagic, NULL, 1, 0 ), PLEAT_RESULT_BAD_MAGIC );
	uint32_t v = 0;
	assert_int_equal( plLoadEdited( f, f->size, plSetVersion, &v, 1, 0 ), PLEAT_RESULT_LEGACY_VERSION );
	v = 2;
	assert_int_equal( plLoadEdited( f, f->size, plSetVersion, &v, 1, 0 ), PLEAT_RESULT_UNSUPPORTED_VERSION );
	v = 1 | ( 7u << 16 ); // 1.7: a newer minor only adds; it loads
	assert_int_equal( plLoadEdited( f, f->size, plSetVersion, &v, 1, 0 ), PLEAT_RESULT_OK );
}

typedef struct plFieldEdit
{
	const char* fourcc; // section whose entry is edited (NULL = header)
	size_t field;       // byte offset in the entry / header
	uint64_t value;
	int width;          // 4 or 8
} plFieldEdit;

static void plEditField( uint8_t* b, size_t size, void* arg )
{
	(void)size;
	const plFieldEdit* e = (const plFieldEdit*)arg;
	size_t base = e->fourcc != NULL ? plTestAsset_SectionEntryOffset( b, e->fourcc ) : 0;
	if ( e->width == 8 )
	{
		plPutU64At( b, base + e->field, e->value );
	}
	else
	{
		plPutU32At( b, base + e->field, (uint32_t)e->value );
	}
}

static void test_broken_structure_is_malformed( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	uint64_t tmpl = plTestAsset_SectionOffset( f->bytes, "TMPL" );
	uint64_t blnd = plTestAsset_SectionOffset( f->bytes, "BLND" );
	const plFieldEdit edits[] = {
		{ NULL, 12, 64, 4 },                 // header_size < 128
		{ NULL, 24, 0, 4 },                  // no sections
		{ NULL, 24, 300, 4 },                // too many sections
		{ NULL, 28, 16, 4 },                 // unknown flag bit (1, 2: int8 networks since 1.3; 3: int8 shapes, 1.4)
		{ NULL, 32, 1ull << 40, 8 },         // table offset past the end
		{ "TMPL", 16, tmpl + 4, 8 },         // offset not 64-byte aligned
		{ "TMPL", 16, 1ull << 62, 8 },       // offset far outside the file
		{ "TMPL", 24, ~0ull - 10, 8 },       // size overflowing offset + size
		{ "TMPL", 24, 12, 8 },               // size inconsistent with dims
		{ "TMPL", 32, 0x40000000u, 4 },      // dims product overflowing the size
		{ "TMPL", 4, 9, 4 },                 // unknown dtype
		{ "TMPL", 8, 5, 4 },                 // rank 5
		{ "TMPL", 44, 2, 4 },                // unused dim not 1
		{ "BLND", 16, tmpl, 8 },             // overlaps TMPL
		{ "TMPL", 0, 0x4C504D54u, 4 },       // placeholder: replaced below by a duplicate fourcc
	};
	(void)blnd;
	for ( size_t i = 0; i + 1 < sizeof( edits ) / sizeof( edits[0] ); ++i )
	{
		plResult r = plLoadEdited( f, f->size, plEditField, (void*)&edits[i], 1, 0 );
		if ( r != PLEAT_RESULT_MALFORMED_ASSET )
		{
			fail_msg( "edit %zu: %s", i, plResultString( r ) );
		}
	}
	// The int8 blend shapes flag on an asset whose BLND is fp32: its content, not its structure.
	plFieldEdit int8_shapes = { NULL, 28, 8, 4 };
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &int8_shapes, 1, 0 ), PLEAT_RESULT_INVALID_ASSET_DATA );
	// Duplicate fourcc: rename SHPB to TMPL.
	plFieldEdit dup = { "SHPB", 0, 0, 4 };
	memcpy( &dup.value, "TMPL", 4 );
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &dup, 1, 0 ), PLEAT_RESULT_MALFORMED_ASSET );
	// file_size smaller than the buffer.
	plFieldEdit shorter = { NULL, 16, f->size - 64, 8 };
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &shorter, 1, 0 ), PLEAT_RESULT_MALFORMED_ASSET );
}

typedef struct plContentEdit
{
	const char* fourcc;
	size_t byte; // offset inside the section data
	uint32_t value;
} plContentEdit;

static void plEditContent( uint8_t* b, size_t size, void* arg )
{
	(void)size;
	const plContentEdit* e = (const plContentEdit*)arg;
	plPutU32At( b, plTestAsset_SectionOffset( b, e->fourcc ) + e->byte, e->value );
}

static void plSwapLayerDims( uint8_t* b, size_t size, void* arg )
{
	(void)size;
	(void)arg;
	size_t e = plTestAsset_SectionEntryOffset( b, "LPW1" );
	uint32_t d0, d1;
	memcpy( &d0, b + e + 32, 4 );
	memcpy( &d1, b + e + 36, 4 );
	memcpy( b + e + 32, &d1, 4 );
	memcpy( b + e + 36, &d0, 4 );
}

// Edits of one value inside a section that leave the file well-formed but its content invalid; the last is valid.
#define PLEAT_NAN_BITS 0x7FC00000u
#define PLEAT_HALF_BITS 0x3F000000u      /* 0.5f */
#define PLEAT_MINUS_ONE_BITS 0xBF800000u /* -1.0f */
static const plContentEdit s_content_edits[] = {
	{ "FACE", 8, 100000 },               // vertex index out of range
	{ "SKNW", 0, PLEAT_HALF_BITS },      // vertex 0's skin weights sum to 0.5 (+ its other weight)
	{ "SKNW", 4, PLEAT_MINUS_ONE_BITS }, // negative skin weight
	{ "TMPL", 4, PLEAT_NAN_BITS },       // non-finite template
	{ "XSTD", 12, 0 },                   // a zero std
	{ "ZSTD", 0, PLEAT_MINUS_ONE_BITS }, // a negative std
	{ "JPAR", 8, 3 },                    // joint 2's parent after it
	{ "JPAR", 0, 0 },                    // root without parent −1
	{ "JINP", 0, 0 },                    // the pelvis as an input joint
	{ "SKNI", 0, 0x00FF00FFu },          // joint index out of range
	{ "NADF", 0, 69 },                   // adjacency face not containing the vertex
	{ "NADO", 4, 1000 },                 // CSR offsets decreasing / out of range
	{ "CONF", 48, 99 },                  // input count not the formula
	{ "CONF", 8, 65 },                   // J over 64
	{ "CONF", 40, 3 },                   // unknown activation
	{ "CONF", 52, 0 },                   // dt_min 0
	{ "LPB0", 0, PLEAT_NAN_BITS },       // non-finite bias
	{ "BANN", 12, PLEAT_HALF_BITS },     // body anchor normal of vertex 1 not unit length (0.5, 0, 1)
	{ "BASI", 0, 0x00FF00FFu },          // body anchor joint index out of range
	{ "BASW", 4, PLEAT_MINUS_ONE_BITS }, // negative body anchor skin weight
	{ "BANC", 8, PLEAT_NAN_BITS },       // non-finite body anchor
	{ "BASH", 0, PLEAT_NAN_BITS },       // non-finite body anchor shape direction
	{ "BACA", 0, 0x70007000u },          // a candidate point index past P that is not the empty slot 0xFFFF
	{ "BARG", 0, 0x00010002u },          // point 0 (an edge point, no ring) given a ring of two
	{ "BARG", 16, 0x70000001u },         // a ring point past P (point 1's ring)
	{ "JNAM", 36, 0x30305F74u },         // joint 1 renamed "joint_00" ("t_00"), joint 0's name
	{ "JNAM", 0, 0x41414141u },          // (valid: name still NUL-terminated) — checked below to load
};
#define PLEAT_CONTENT_EDITS ( sizeof( s_content_edits ) / sizeof( s_content_edits[0] ) )

static void test_broken_content_is_invalid_asset_data( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	const plContentEdit* edits = s_content_edits;
	for ( size_t i = 0; i + 1 < PLEAT_CONTENT_EDITS; ++i )
	{
		plResult r = plLoadEdited( f, f->size, plEditContent, (void*)&edits[i], 1, 0 );
		if ( r != PLEAT_RESULT_INVALID_ASSET_DATA )
		{
			fail_msg( "edit %zu (%s): %s", i, edits[i].fourcc, plResultString( r ) );
		}
	}
	assert_int_equal( plLoadEdited( f, f->size, plEditContent, (void*)&edits[PLEAT_CONTENT_EDITS - 1], 1, 0 ),
					  PLEAT_RESULT_OK );
	// The body-contact block is all or none: one of its five sections missing (renamed away) is invalid.
	plFieldEdit drop_basw = { "BASW", 0, 0, 4 };
	memcpy( &drop_basw.value, "BASX", 4 );
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &drop_basw, 1, 0 ), PLEAT_RESULT_INVALID_ASSET_DATA );
	// Without BACA the points must be one per vertex (1.1): P = N + N/4 rows with the table renamed away is invalid.
	plFieldEdit drop_baca = { "BACA", 0, 0, 4 };
	memcpy( &drop_baca.value, "BACX", 4 );
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &drop_baca, 1, 0 ), PLEAT_RESULT_INVALID_ASSET_DATA );
	// A missing required section (TMPL renamed to an unknown fourcc, which a 1.x reader ignores).
	plFieldEdit rename = { "TMPL", 0, 0, 4 };
	memcpy( &rename.value, "TMPX", 4 );
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &rename, 1, 0 ), PLEAT_RESULT_INVALID_ASSET_DATA );
	// A layer chain that does not connect: LPW1 [12, 16] relabelled [16, 12] (same size, so structurally sound).
	assert_int_equal( plLoadEdited( f, f->size, plSwapLayerDims, NULL, 1, 0 ), PLEAT_RESULT_INVALID_ASSET_DATA );
	// Changing only one dim makes the size inconsistent: that is structure, not content.
	plFieldEdit one_dim = { "LPW1", 36, 5, 4 };
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &one_dim, 1, 0 ), PLEAT_RESULT_MALFORMED_ASSET );
}

// A content rejection names its section in the load's error log line, so an integrator learns where a broken asset is
// broken: every edit of the content table, a missing section, a layer chain that does not connect, and a section-table
// entry whose size does not match its dims.
static void test_a_broken_section_is_named_in_the_log( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	plTestLog log;
	memset( &log, 0, sizeof( log ) );
	plContextDef def = plDefaultContextDef();
	def.log = plTestLog_Record;
	def.log_context = &log;
	plContext quiet = f->context;
	assert_int_equal( plCreateContext( &def, &f->context ), PLEAT_RESULT_OK );
	for ( size_t i = 0; i + 1 < PLEAT_CONTENT_EDITS; ++i )
	{
		log.last_error[0] = 0;
		assert_int_equal( plLoadEdited( f, f->size, plEditContent, (void*)&s_content_edits[i], 1, 0 ),
						  PLEAT_RESULT_INVALID_ASSET_DATA );
		if ( strstr( log.last_error, s_content_edits[i].fourcc ) == NULL ||
			 log.last_error_item != PLEAT_LOG_ASSET_BAD_CONTENT )
		{
			fail_msg( "edit %zu (%s) logged item %d: '%s'", i, s_content_edits[i].fourcc, (int)log.last_error_item,
					  log.last_error );
		}
	}
	plFieldEdit rename = { "TMPL", 0, 0, 4 };
	memcpy( &rename.value, "TMPX", 4 );
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &rename, 1, 0 ), PLEAT_RESULT_INVALID_ASSET_DATA );
	assert_non_null( strstr( log.last_error, "TMPL" ) );
	assert_int_equal( plLoadEdited( f, f->size, plSwapLayerDims, NULL, 1, 0 ), PLEAT_RESULT_INVALID_ASSET_DATA );
	assert_non_null( strstr( log.last_error, "LPW1" ) );
	plFieldEdit size = { "TMPL", 24, 12, 8 };
	assert_int_equal( plLoadEdited( f, f->size, plEditField, &size, 1, 0 ), PLEAT_RESULT_MALFORMED_ASSET );
	assert_non_null( strstr( log.last_error, "TMPL" ) );
	assert_int_equal( log.last_error_item, PLEAT_LOG_ASSET_BAD_SECTION_TABLE );
	uint64_t live = 1;
	plContext_GetLiveBytes( f->context, &live );
	assert_int_equal( live, 0 );
	plDestroyContext( f->context );
	f->context = quiet;
}

// fp16 weights load and are flagged; an fp16 section without the header flag is invalid.
static void test_fp16_weights_need_the_header_flag( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.fp16 = 1;
	plTestAsset* model = plTestAsset_Create( &p );
	size_t size;
	uint8_t* bytes = plTestAsset_Write( model, &size );
	plAssetDef def = plDefaultAssetDef();
	def.data = bytes;
	def.size = size;
	plAsset asset;
	assert_int_equal( plLoadAsset( f->context, &def, &asset ), PLEAT_RESULT_OK );
	plAssetInfo info;
	plAsset_GetInfo( asset, &info );
	assert_true( info.weights_fp16 );
	plDestroyAsset( asset );
	plPutU32At( bytes, 28, 0 );
	plTestAsset_FixChecksum( bytes, size );
	assert_int_equal( plLoadAsset( f->context, &def, &asset ), PLEAT_RESULT_INVALID_ASSET_DATA );
	plTestAsset_FreeBytes( bytes );
	plTestAsset_Destroy( model );
}

// Thousands of random corruptions (checksum skipped so they reach the structure and content checks): the loader
// returns an error or OK and never crashes or reads outside the buffer (ASan in the sanitizer build).
static void test_random_corruption_never_crashes( void** state )
{
	plLoaderFixture* f = (plLoaderFixture*)*state;
	uint32_t rng = 99;
	uint8_t* copy = (uint8_t*)aligned_alloc( 64, ( f->size + 63 ) & ~(size_t)63 );
	int rejected = 0;
	for ( int trial = 0; trial < 3000; ++trial )
	{
		memcpy( copy, f->bytes, f->size );
		int flips = 1 + trial % 4;
		for ( int k = 0; k < flips; ++k )
		{
			rng ^= rng << 13;
			rng ^= rng >> 17;
			rng ^= rng << 5;
			// Bias towards the header and table, where structure lives.
			size_t limit = ( trial & 1 ) ? f->size : 128 + 48 * 40;
			copy[rng % limit] ^= (uint8_t)( 1u << ( ( rng >> 24 ) & 7u ) );
		}
		size_t size = ( trial % 7 == 0 ) ? ( rng % f->size ) : f->size;
		plAssetDef def = plDefaultAssetDef();
		def.data = copy;
		def.size = size;
		def.flags = PLEAT_ASSET_FLAG_SKIP_CHECKSUM | PLEAT_ASSET_FLAG_USE_IN_PLACE;
		plAsset asset;
		plResult r = plLoadAsset( f->context, &def, &asset );
		if ( r == PLEAT_RESULT_OK )
		{
			plDestroyAsset( asset );
		}
		else
		{
			rejected++;
		}
	}
	assert_true( rejected > 1000 );
	free( copy );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_crc32_matches_zlib_definition ),
		cmocka_unit_test_setup_teardown( test_valid_asset_loads_copied_in_place_and_from_file, plLoaderSetup,
										 plLoaderTeardown ),
		cmocka_unit_test_setup_teardown( test_truncated_asset_is_rejected, plLoaderSetup, plLoaderTeardown ),
		cmocka_unit_test_setup_teardown( test_flipped_bytes_fail_the_checksum, plLoaderSetup, plLoaderTeardown ),
		cmocka_unit_test_setup_teardown( test_wrong_magic_and_versions_are_rejected, plLoaderSetup, plLoaderTeardown ),
		cmocka_unit_test_setup_teardown( test_broken_structure_is_malformed, plLoaderSetup, plLoaderTeardown ),
		cmocka_unit_test_setup_teardown( test_broken_content_is_invalid_asset_data, plLoaderSetup, plLoaderTeardown ),
		cmocka_unit_test_setup_teardown( test_a_broken_section_is_named_in_the_log, plLoaderSetup, plLoaderTeardown ),
		cmocka_unit_test_setup_teardown( test_fp16_weights_need_the_header_flag, plLoaderSetup, plLoaderTeardown ),
		cmocka_unit_test_setup_teardown( test_random_corruption_never_crashes, plLoaderSetup, plLoaderTeardown ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
