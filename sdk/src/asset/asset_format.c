// The asset file's container (asset_format.h): header, section table, CRC-32, and the declarative section reader.
// Structure and overflow are checked before any pointer into the buffer is made; the reader then checks each
// section's dtype, dims and values before its pointer is stored.
#include "asset_format.h"

#include "jobs/jobs.h"

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>

#if defined( __BYTE_ORDER__ ) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "Pleat assets are little-endian and read in place; a big-endian port needs a byte-swapping loader"
#endif

static uint64_t plReadU64( const uint8_t* p )
{
	return (uint64_t)plReadU32( p ) | ( (uint64_t)plReadU32( p + 4 ) << 32 );
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
		case PLEAT_DTYPE_I8:
			return 1;
		default:
			return 0;
	}
}

// ---- structure ----

// The four characters of a fourcc, printable ones only (a corrupted entry may hold anything).
static void plFourccText( uint32_t fourcc, char text[5] )
{
	for ( int c = 0; c < 4; ++c )
	{
		char ch = (char)( ( fourcc >> ( 8 * c ) ) & 0xFFu );
		text[c] = ch >= 0x20 && ch < 0x7F ? ch : '?';
	}
	text[4] = 0;
}

static plResult plMalformedEntry( plAssetData* a, uint32_t index, const plSection* s, const char* why )
{
	char text[5];
	plFourccText( s->fourcc, text );
	snprintf( a->rejected_detail, sizeof( a->rejected_detail ), "section %u (%s): %s", index, text, why );
	return PLEAT_RESULT_MALFORMED_ASSET;
}

plResult plReadSectionTable( const uint8_t* data, size_t size, int skip_checksum, plSectionTable* table,
							 uint32_t* out_flags, plAssetData* a )
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
	uint16_t major = (uint16_t)( data[8] | ( data[9] << 8 ) );
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
		 section_count < 1 || section_count > PLEAT_MAX_SECTIONS ||
		 ( flags & ~PLEAT_KNOWN_FLAGS ) != 0 ||
		 table_offset < header_size ||
		 table_offset > size || (uint64_t)section_count * PLEAT_SECTION_ENTRY_SIZE > size - table_offset )
	{
		snprintf( a->rejected_detail, sizeof( a->rejected_detail ), "header: sizes or flags out of range" );
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
			return plMalformedEntry( a, i, s, "dtype, rank, alignment or bounds" );
		}
		uint64_t elements = 1;
		for ( uint32_t d = 0; d < 4; ++d )
		{
			s->dims[d] = plReadU32( e + 32 + 4 * d );
			if ( d >= s->rank && s->dims[d] != 1 )
			{
				return plMalformedEntry( a, i, s, "a dim past its rank is not 1" );
			}
			// The product stays below 2^64 because each factor is checked against the file size first.
			if ( s->dims[d] != 0 && elements > (uint64_t)size / s->dims[d] )
			{
				return plMalformedEntry( a, i, s, "dims larger than the file" );
			}
			elements *= s->dims[d];
		}
		if ( elements * dtype_size != s->size )
		{
			return plMalformedEntry( a, i, s, "size is not its dims times its dtype's size" );
		}
		for ( uint32_t j = 0; j < i; ++j )
		{
			const plSection* o = &table->sections[j];
			if ( o->fourcc == s->fourcc )
			{
				return plMalformedEntry( a, i, s, "a second section with this fourcc" );
			}
			if ( s->size != 0 && o->size != 0 && s->offset < o->offset + o->size && o->offset < s->offset + s->size )
			{
				return plMalformedEntry( a, i, s, "overlaps another section" );
			}
		}
	}
	*out_flags = flags;
	return PLEAT_RESULT_OK;
}

const plSection* plFindSection( const plSectionTable* table, const char* fourcc )
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

// ---- the declarative reader ----

plResult plRejectSection( plAssetData* a, const char* fourcc, const char* format, ... )
{
	int n = snprintf( a->rejected_detail, sizeof( a->rejected_detail ), "%s: ", fourcc );
	if ( n > 0 && (size_t)n < sizeof( a->rejected_detail ) )
	{
		va_list args;
		va_start( args, format );
		vsnprintf( a->rejected_detail + n, sizeof( a->rejected_detail ) - (size_t)n, format, args );
		va_end( args );
	}
	return PLEAT_RESULT_INVALID_ASSET_DATA;
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

static const char* plDtypeName( uint32_t dtype )
{
	static const char* const names[] = { "?", "f32", "f16", "u32", "u16", "i32", "u8", "i8" };
	return dtype < sizeof( names ) / sizeof( names[0] ) ? names[dtype] : "?";
}

// A section's value checks (the spec's PLEAT_SECTION_FINITE / _POSITIVE); NULL if they pass, else why not.
static const char* plCheckValues( const plSectionSpec* spec, const void* p, int fp16, uint64_t count )
{
	if ( ( spec->checks & PLEAT_SECTION_FINITE ) != 0 &&
		 ( fp16 ? !plAllFiniteHalf( (const uint16_t*)p, count ) : !plAllFiniteFloats( (const float*)p, count ) ) )
	{
		return "a value is not finite";
	}
	if ( ( spec->checks & PLEAT_SECTION_SYMMETRIC_I8 ) != 0 )
	{
		const int8_t* v = (const int8_t*)p;
		for ( uint64_t i = 0; i < count; ++i )
		{
			if ( v[i] == INT8_MIN )
			{
				return "a value is -128 (int8 weights are symmetric, -127..127)";
			}
		}
	}
	if ( ( spec->checks & PLEAT_SECTION_POSITIVE ) != 0 )
	{
		const float* v = (const float*)p;
		for ( uint64_t i = 0; i < count; ++i )
		{
			if ( !( v[i] > 0.0f ) )
			{
				return "a value is not above zero";
			}
		}
	}
	return NULL;
}

static void plStorePointer( void* out, uint16_t field, const void* p )
{
	memcpy( (uint8_t*)out + field, &p, sizeof( p ) ); // the field is a const T* of the spec's dtype
}

plResult plReadSections( const uint8_t* data, const plSectionTable* table, uint32_t flags, const plSectionSpec* specs,
						 uint32_t count, const uint32_t* sizes, void* out, plAssetData* a )
{
	static const float no_floats[1] = { 0.0f };
	for ( uint32_t i = 0; i < count; ++i )
	{
		const plSectionSpec* spec = &specs[i];
		const plSection* s = plFindSection( table, spec->fourcc );
		if ( s == NULL )
		{
			if ( ( spec->checks & PLEAT_SECTION_OPTIONAL ) != 0 )
			{
				plStorePointer( out, spec->field, NULL );
				continue;
			}
			if ( ( spec->checks & PLEAT_SECTION_EMPTY_WITHOUT_B ) != 0 && sizes[PLEAT_DIM_B] == 0 )
			{
				plStorePointer( out, spec->field, no_floats ); // a shape-less asset may leave out its [0][..] sections
				continue;
			}
			return plRejectSection( a, spec->fourcc, "(%s) missing", spec->what );
		}
		int fp16 = spec->dtype == PLEAT_DTYPE_WEIGHTS && s->dtype == PLEAT_DTYPE_F16;
		if ( fp16 && ( flags & PLEAT_FLAG_FP16 ) == 0 )
		{
			return plRejectSection( a, spec->fourcc, "(%s) fp16 without the header's fp16 flag", spec->what );
		}
		uint32_t weights_dtype = fp16 ? PLEAT_DTYPE_F16 : PLEAT_DTYPE_F32;
		uint32_t dtype = spec->dtype == PLEAT_DTYPE_WEIGHTS ? weights_dtype : spec->dtype;
		uint32_t expected[3] = { 1, 1, 1 };
		int dims_match = s->dtype == dtype && s->rank == spec->rank;
		uint64_t values = 1;
		for ( uint32_t d = 0; d < spec->rank; ++d )
		{
			expected[d] = sizes[spec->dims[d]];
			dims_match = dims_match && s->dims[d] == expected[d];
			values *= expected[d];
		}
		if ( !dims_match )
		{
			return plRejectSection( a, spec->fourcc, "(%s) %s rank %u [%u, %u, %u], expected %s rank %u [%u, %u, %u]",
									spec->what, plDtypeName( s->dtype ), s->rank, s->dims[0], s->dims[1], s->dims[2],
									plDtypeName( dtype ), spec->rank, expected[0], expected[1], expected[2] );
		}
		// A zero-sized section still needs a valid pointer; its offset is inside the file.
		const void* p = data + s->offset;
		const char* why = plCheckValues( spec, p, fp16, values );
		if ( why != NULL )
		{
			return plRejectSection( a, spec->fourcc, "(%s) %s", spec->what, why );
		}
		plStorePointer( out, spec->field, p );
		if ( spec->dtype == PLEAT_DTYPE_WEIGHTS )
		{
			memcpy( (uint8_t*)out + spec->fp16_field, &fp16, sizeof( fp16 ) );
		}
	}
	return PLEAT_RESULT_OK;
}
