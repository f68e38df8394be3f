// Internal: the asset file's container (docs/asset-format.md): the header, the section table {fourcc, dtype, rank,
// offset, size, dims}, the CRC-32, and the reader of a declarative table of sections (plSectionSpec): each entry names
// a section, its dtype and dims in the asset's counts, the checks its values must pass and the field of plAssetData it
// fills, so every section is read by one loop and a rejection names the section it is about.
#ifndef PLEAT_ASSET_FORMAT_H
#define PLEAT_ASSET_FORMAT_H
#include "asset_data.h"

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define PLEAT_HEADER_SIZE 128u
#define PLEAT_SECTION_ENTRY_SIZE 48u
#define PLEAT_MAX_SECTIONS 256u
#define PLEAT_CONF_SIZE 256u
// Header flags (offset 28): bit 0 some weights are fp16; bit 1 (1.3) the networks are int8; bit 2 (1.3, with bit 1
// and ReLU networks) the int8 layers' inputs are ranged (plInt8Input; docs/asset-format.md "int8 networks"); bit 3
// (1.4) the blend shapes are int8 with a scale per shape (BLND i8, BLSC; "int8 blend shapes").
#define PLEAT_FLAG_FP16 1u
#define PLEAT_FLAG_INT8 2u
#define PLEAT_FLAG_INT8_RANGED_INPUTS 4u
#define PLEAT_FLAG_INT8_BLEND_SHAPES 8u
#define PLEAT_KNOWN_FLAGS                                                                                              \
	( PLEAT_FLAG_FP16 | PLEAT_FLAG_INT8 | PLEAT_FLAG_INT8_RANGED_INPUTS | PLEAT_FLAG_INT8_BLEND_SHAPES )

enum
{
	PLEAT_DTYPE_F32 = 1,
	PLEAT_DTYPE_F16 = 2,
	PLEAT_DTYPE_U32 = 3,
	PLEAT_DTYPE_U16 = 4,
	PLEAT_DTYPE_I32 = 5,
	PLEAT_DTYPE_U8 = 6,
	PLEAT_DTYPE_I8 = 7, // 1.3: the int8 networks' weights
	PLEAT_DTYPE_WEIGHTS = 100, // a spec's dtype only: F32, or F16 where the header's fp16 flag is set
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

// Little-endian reads at any alignment.
static inline uint32_t plReadU32( const uint8_t* p )
{
	return (uint32_t)p[0] | ( (uint32_t)p[1] << 8 ) | ( (uint32_t)p[2] << 16 ) | ( (uint32_t)p[3] << 24 );
}

static inline float plReadF32( const uint8_t* p )
{
	uint32_t u = plReadU32( p );
	float f;
	memcpy( &f, &u, sizeof( f ) );
	return f;
}

uint32_t plCrc32( uint32_t crc, const uint8_t* data, size_t size );

// The header and the section table: magic, version, sizes, the checksum (unless skip_checksum), then every entry's
// dtype, rank, alignment, bounds, size = dims × dtype size, no duplicate fourcc, no overlap — before any pointer into
// data is made. *out_flags: the header's flags. A malformed entry is named in a->rejected_detail.
plResult plReadSectionTable( const uint8_t* data, size_t size, int skip_checksum, plSectionTable* table,
							 uint32_t* out_flags, plAssetData* a );
// The entry of a fourcc ("TMPL"), or NULL.
const plSection* plFindSection( const plSectionTable* table, const char* fourcc );

// The sizes a spec's dims name, resolved from CONF (and, for the body contact, from its own sections).
typedef enum plSectionDim
{
	PLEAT_DIM_3,         // 3: a position, a normal or a triangle
	PLEAT_DIM_N,         // vertices
	PLEAT_DIM_N_PLUS_1,  // the adjacency offsets
	PLEAT_DIM_F,         // faces
	PLEAT_DIM_3F,        // the adjacency's face list
	PLEAT_DIM_J,         // joints
	PLEAT_DIM_JIN,       // input joints
	PLEAT_DIM_K,         // skin influences per vertex
	PLEAT_DIM_B,         // shape coefficients β
	PLEAT_DIM_L,         // latent
	PLEAT_DIM_I,         // f_LP's input X_c
	PLEAT_DIM_D,         // blend shapes
	PLEAT_DIM_NAME,      // PLEAT_JOINT_NAME_SIZE
	PLEAT_DIM_CONF,      // PLEAT_CONF_SIZE
	PLEAT_DIM_P,         // body points
	PLEAT_DIM_KA,        // skin influences per body point
	PLEAT_DIM_C,         // contact candidates per vertex
	PLEAT_DIM_R,         // ring entries per body point
	PLEAT_DIM_1,         // 1: a scalar (an int8 layer's input scale); the readers that use it set it
	PLEAT_DIM_COUNT
} plSectionDim;

enum
{
	PLEAT_SECTION_OPTIONAL = 1u << 0,       // may be absent: the field stays NULL
	PLEAT_SECTION_FINITE = 1u << 1,         // every value finite
	PLEAT_SECTION_POSITIVE = 1u << 2,       // every value > 0 (after the finite check)
	PLEAT_SECTION_EMPTY_WITHOUT_B = 1u << 3, // may be absent when B = 0: the field points at a zero float
	PLEAT_SECTION_SYMMETRIC_I8 = 1u << 4     // int8 values in [−127, 127] (no −128: the int8 kernels' sign trick)
};

// One section as the loader reads it.
typedef struct plSectionSpec
{
	char fourcc[5];
	uint8_t dtype;      // PLEAT_DTYPE_*, PLEAT_DTYPE_WEIGHTS for fp32-or-fp16 tensors
	uint8_t rank;       // the section's rank, 1..3
	uint8_t dims[3];    // plSectionDim of each of the first rank dims
	uint8_t checks;     // PLEAT_SECTION_*
	uint16_t field;     // offsetof( the struct read into, the pointer it sets ): plAssetData, or plLayer
	uint16_t fp16_field; // PLEAT_DTYPE_WEIGHTS: offsetof( that struct, the int set to 1 for fp16 )
	const char* what;   // what it holds, for the log
} plSectionSpec;

// Reads count specs in order: each present section's dtype, rank and dims checked against sizes[plSectionDim], its
// values against the spec's checks, then its pointer stored in the spec's field of *out (the asset itself, or a
// layer). The first section that fails is named in a->rejected_detail ("TMPL: (template positions) ...") and
// PLEAT_RESULT_INVALID_ASSET_DATA returned.
plResult plReadSections( const uint8_t* data, const plSectionTable* table, uint32_t flags, const plSectionSpec* specs,
						 uint32_t count, const uint32_t* sizes, void* out, plAssetData* a );
// Names a rejected section in a->rejected_detail ("FOURCC: why", printf-style) and returns
// PLEAT_RESULT_INVALID_ASSET_DATA (the meaning checks' rejections).
plResult plRejectSection( plAssetData* a, const char* fourcc, const char* format, ... )
#if defined( __GNUC__ )
	__attribute__( ( format( printf, 3, 4 ) ) )
#endif
	;

#endif
