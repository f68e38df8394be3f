// What an asset's sections mean (asset_validate.h). The sections every asset has are one table (s_sections): each
// row the section's fourcc, dtype, dims in the counts CONF gives, the checks on its values and the field it fills,
// read by plReadSections; the optional blocks (body contact) have tables of their own, read once their counts are
// known. The checks across sections follow. Every rejection names its section (plRejectSection), which the load's log
// line carries, so a broken asset says where it is broken.
#include "asset_validate.h"

#include "asset_format.h"
#include "jobs/jobs.h"
#include "onnx_model.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#define PLEAT_SPEC( fourcc, dtype, rank, d0, d1, d2, checks, field, what )                                             \
	{ fourcc, PLEAT_DTYPE_##dtype, rank, { PLEAT_DIM_##d0, PLEAT_DIM_##d1, PLEAT_DIM_##d2 }, checks,                   \
	  (uint16_t)offsetof( plAssetData, field ), 0, what }

enum
{
	FINITE = PLEAT_SECTION_FINITE,
	POSITIVE = PLEAT_SECTION_FINITE | PLEAT_SECTION_POSITIVE,
	SHAPE = PLEAT_SECTION_FINITE | PLEAT_SECTION_EMPTY_WITHOUT_B,
	OPTIONAL = PLEAT_SECTION_OPTIONAL,
};

// The sections of every asset (docs/asset-format.md "Sections"), in the order they are read. (Unused dims: 3.)
static const plSectionSpec s_sections[] = {
	PLEAT_SPEC( "JNAM", U8, 2, J, NAME, 3, 0, joint_names, "joint names" ),
	PLEAT_SPEC( "JPAR", I32, 1, J, 3, 3, 0, parents, "joint parents" ),
	PLEAT_SPEC( "JTPL", F32, 2, J, 3, 3, FINITE, joint_template, "template joints" ),
	PLEAT_SPEC( "JSHP", F32, 3, B, J, 3, SHAPE, joint_shapedirs, "joint shape directions" ),
	PLEAT_SPEC( "JINP", U32, 1, JIN, 3, 3, 0, input_joints, "input joints" ),
	PLEAT_SPEC( "TMPL", F32, 2, N, 3, 3, FINITE, template_positions, "template positions" ),
	PLEAT_SPEC( "SHPB", F32, 3, B, N, 3, SHAPE, shape_blend, "shape blend directions" ),
	PLEAT_SPEC( "FACE", U32, 2, F, 3, 3, 0, faces, "faces" ),
	PLEAT_SPEC( "NADO", U32, 1, N_PLUS_1, 3, 3, 0, adjacency_offsets, "normals adjacency offsets" ),
	PLEAT_SPEC( "NADF", U32, 1, 3F, 3, 3, 0, adjacency_faces, "normals adjacency faces" ),
	PLEAT_SPEC( "SKNI", U16, 2, N, K, 3, 0, skin_indices, "skin joint indices" ),
	PLEAT_SPEC( "SKNW", F32, 2, N, K, 3, 0, skin_weights, "skin weights" ),
	PLEAT_SPEC( "XMEA", F32, 1, I, 3, 3, FINITE, x_mean, "X_c mean" ),
	PLEAT_SPEC( "XSTD", F32, 1, I, 3, 3, POSITIVE, x_std, "X_c standard deviation" ),
	PLEAT_SPEC( "ZMEA", F32, 1, L, 3, 3, FINITE, z_mean, "latent mean" ),
	PLEAT_SPEC( "ZSTD", F32, 1, L, 3, 3, POSITIVE, z_std, "latent standard deviation" ),
	PLEAT_SPEC( "ZMIN", F32, 1, L, 3, 3, FINITE, z_min, "latent lower bound" ),
	PLEAT_SPEC( "ZMAX", F32, 1, L, 3, 3, FINITE, z_max, "latent upper bound" ),
};

// The blend shapes: fp32 or fp16 (the header's fp16 flag), or with the int8 blend shapes flag (asset 1.4) int8 with a
// scale per shape.
static const plSectionSpec s_blend_sections[] = {
	{ "BLND", PLEAT_DTYPE_WEIGHTS, 3, { PLEAT_DIM_D, PLEAT_DIM_N, PLEAT_DIM_3 }, FINITE,
	  (uint16_t)offsetof( plAssetData, blend_shapes.data ), (uint16_t)offsetof( plAssetData, blend_shapes.type ),
	  "blend shapes" },
};
static const plSectionSpec s_int8_blend_sections[] = {
	{ "BLND", PLEAT_DTYPE_I8, 3, { PLEAT_DIM_D, PLEAT_DIM_N, PLEAT_DIM_3 }, PLEAT_SECTION_SYMMETRIC_I8,
	  (uint16_t)offsetof( plAssetData, blend_shapes.data ), 0, "int8 blend shapes" },
	PLEAT_SPEC( "BLSC", F32, 1, D, 3, 3, POSITIVE, blend_shapes.scales, "blend shape scales" ),
};

// The body contact (asset 1.1 and later, all five or none), once P and Ka are known; BACA and BARG (1.2) apart.
static const plSectionSpec s_body_sections[] = {
	PLEAT_SPEC( "BANC", F32, 2, P, 3, 3, FINITE, body_anchors, "body points" ),
	PLEAT_SPEC( "BASH", F32, 3, B, P, 3, FINITE, body_anchor_shape, "body point shape directions" ),
	PLEAT_SPEC( "BANN", F32, 2, P, 3, 3, FINITE, body_anchor_normals, "body point normals" ),
	PLEAT_SPEC( "BASI", U16, 2, P, KA, 3, 0, body_anchor_skin_indices, "body point skin joint indices" ),
	PLEAT_SPEC( "BASW", F32, 2, P, KA, 3, 0, body_anchor_skin_weights, "body point skin weights" ),
};
static const plSectionSpec s_candidates_section = PLEAT_SPEC( "BACA", U16, 2, N, C, 3, 0, body_anchor_candidates,
															  "contact candidates" );
static const plSectionSpec s_rings_section = PLEAT_SPEC( "BARG", U16, 2, P, R, 3, 0, body_anchor_ring,
														 "body point rings" );

#define PLEAT_SPEC_COUNT( specs ) ( (uint32_t)( sizeof( specs ) / sizeof( ( specs )[0] ) ) )

// ---- CONF: the counts and ranges ----

static plResult plReadConf( const uint8_t* data, const plSectionTable* table, uint32_t flags, plAssetData* a )
{
	const plSection* s = plFindSection( table, "CONF" );
	if ( s == NULL || s->dtype != PLEAT_DTYPE_U8 || s->rank != 1 || s->dims[0] != PLEAT_CONF_SIZE )
	{
		return plRejectSection( a, "CONF", "(counts and ranges) missing or not u8 [%u]", PLEAT_CONF_SIZE );
	}
	const uint8_t* conf = data + s->offset;
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
	a->weights_fp16 = ( flags & PLEAT_FLAG_FP16 ) != 0;
	a->weights_int8 = ( flags & PLEAT_FLAG_INT8 ) != 0;

	uint32_t N = a->vertex_count, F = a->face_count, J = a->joint_count, Jin = a->input_joint_count;
	uint32_t K = a->influence_count, B = a->beta_count, L = a->latent_count, D = a->blend_count;
	if ( N == 0 || N > ( 1u << 24 ) || F == 0 || F > ( 1u << 25 ) || J == 0 || J > PLEAT_MAX_JOINTS || Jin >= J ||
		 K < 1 || K > PLEAT_MAX_INFLUENCES || B > PLEAT_MAX_BETAS || L == 0 || L > 65536 || D == 0 || D > 65536 ||
		 a->lp_layer_count < 1 || a->lp_layer_count > PLEAT_MAX_LAYERS || a->dec_layer_count < 1 ||
		 a->dec_layer_count > PLEAT_MAX_LAYERS || a->lp_activation < 1 || a->lp_activation > 2 ||
		 a->dec_activation < 1 || a->dec_activation > 2 ||
		 (uint64_t)a->input_count != plInputCountFormula( L, Jin, B ) )
	{
		return plRejectSection( a, "CONF", "a count out of range (N %u, F %u, J %u, Jin %u, K %u, B %u, L %u, D %u, "
										   "layers %u/%u, activations %u/%u, I %u)",
								N, F, J, Jin, K, B, L, D, a->lp_layer_count, a->dec_layer_count, a->lp_activation,
								a->dec_activation, a->input_count );
	}
	// Ranged int8 inputs hold hidden layers' inputs as never negative: int8 ReLU networks only.
	if ( ( flags & PLEAT_FLAG_INT8_RANGED_INPUTS ) != 0 &&
		 ( !a->weights_int8 || a->lp_activation != PLEAT_ACTIVATION_RELU || a->dec_activation != PLEAT_ACTIVATION_RELU ) )
	{
		return plRejectSection( a, "CONF", "the header's ranged int8 inputs flag needs int8 ReLU networks "
										   "(int8 %d, activations %u/%u)",
								a->weights_int8, a->lp_activation, a->dec_activation );
	}
	// Written this way so NaN fails every comparison.
	if ( !( a->dt_min_s > 0.0f && a->dt_min_s <= a->dt_max_s && a->dt_max_s <= 1.0f ) ||
		 !( a->beta_min <= a->beta_max ) || !isfinite( a->beta_min ) || !isfinite( a->beta_max ) ||
		 !isfinite( a->train_fps ) )
	{
		return plRejectSection( a, "CONF", "dt, β or training fps range invalid" );
	}
	for ( int i = 0; i < 4; ++i )
	{
		if ( !isfinite( a->material_min[i] ) || !isfinite( a->material_max[i] ) ||
			 !( a->material_min[i] < a->material_max[i] ) || !( a->material_default[i] >= a->material_min[i] ) ||
			 !( a->material_default[i] <= a->material_max[i] ) )
		{
			return plRejectSection( a, "CONF", "material parameter %d range invalid", i );
		}
	}
	return PLEAT_RESULT_OK;
}

// ---- checks across sections ----

// Skin rows [N][K]: finite, non-negative weights summing to 1 ± 1e-3, joints < J. Returns the first bad row, or N.
static uint32_t plFirstBadSkinRow( const uint16_t* indices, const float* weights, uint32_t N, uint32_t K, uint32_t J )
{
	for ( uint32_t v = 0; v < N; ++v )
	{
		double sum = 0.0;
		for ( uint32_t k = 0; k < K; ++k )
		{
			float w = weights[(size_t)v * K + k];
			if ( !isfinite( w ) || w < 0.0f || indices[(size_t)v * K + k] >= J )
			{
				return v;
			}
			sum += w;
		}
		if ( fabs( sum - 1.0 ) > 1e-3 )
		{
			return v;
		}
	}
	return N;
}

// Layer i of an int8 network (1.3, the header's int8 flag): the weights int8 in [−127, 127], each output channel's
// scale (LPSi / DCSi, [out], > 0) and the scale its input is quantised with (LPAi / DCAi, [1], > 0, its reciprocal
// finite too), then the bias as in any layer; where its input is quantised to follows from the ranged-inputs flag and
// i (plInt8Input; a HIDDEN layer's offsets are derived at load). The kernels quantise the input on their stack: at
// most PLEAT_MAX_INT8_COLUMNS inputs.
static plResult plReadInt8Layer( const uint8_t* data, const plSectionTable* table, uint32_t flags, const char* prefix,
								 uint32_t i, plSectionSpec bias, const uint32_t* sizes, plLayer* layer, plAssetData* a )
{
	char wname[5] = { prefix[0], prefix[1], 'W', (char)( '0' + i ), 0 };
	char sname[5] = { prefix[0], prefix[1], 'S', (char)( '0' + i ), 0 };
	char aname[5] = { prefix[0], prefix[1], 'A', (char)( '0' + i ), 0 };
	if ( sizes[PLEAT_DIM_I] > PLEAT_MAX_INT8_COLUMNS )
	{
		return plRejectSection( a, wname, "(int8 layer weights) %u inputs, at most %u", sizes[PLEAT_DIM_I],
								PLEAT_MAX_INT8_COLUMNS );
	}
	plSectionSpec specs[4] = {
		{ { 0 }, PLEAT_DTYPE_I8, 2, { PLEAT_DIM_D, PLEAT_DIM_I, PLEAT_DIM_3 }, PLEAT_SECTION_SYMMETRIC_I8,
		  (uint16_t)offsetof( plLayer, weight ), 0, "int8 layer weights" },
		{ { 0 }, PLEAT_DTYPE_F32, 1, { PLEAT_DIM_D, PLEAT_DIM_3, PLEAT_DIM_3 },
		  PLEAT_SECTION_FINITE | PLEAT_SECTION_POSITIVE, (uint16_t)offsetof( plLayer, weight_scale ), 0,
		  "int8 layer's output-channel scales" },
		{ { 0 }, PLEAT_DTYPE_F32, 1, { PLEAT_DIM_1, PLEAT_DIM_3, PLEAT_DIM_3 },
		  PLEAT_SECTION_FINITE | PLEAT_SECTION_POSITIVE, (uint16_t)offsetof( plLayer, input_scale ), 0,
		  "int8 layer's input scale" },
		bias };
	memcpy( specs[0].fourcc, wname, 5 );
	memcpy( specs[1].fourcc, sname, 5 );
	memcpy( specs[2].fourcc, aname, 5 );
	uint32_t layer_sizes[PLEAT_DIM_COUNT];
	memcpy( layer_sizes, sizes, sizeof( layer_sizes ) );
	layer_sizes[PLEAT_DIM_1] = 1;
	plResult r = plReadSections( data, table, flags, specs, 4, layer_sizes, layer, a );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	float inverse = 1.0f / layer->input_scale[0];
	if ( !( inverse < INFINITY ) )
	{
		return plRejectSection( a, aname, "(int8 layer's input scale) %g has no finite reciprocal",
								(double)layer->input_scale[0] );
	}
	layer->weight_int8 = 1;
	layer->weight_fp16 = 0;
	layer->input_inv_scale = inverse;
	layer->int8_input = ( flags & PLEAT_FLAG_INT8_RANGED_INPUTS ) == 0 ? PLEAT_INT8_INPUT_SYMMETRIC
						: i == 0										? PLEAT_INT8_INPUT_FIRST
																		: PLEAT_INT8_INPUT_HIDDEN;
	return PLEAT_RESULT_OK;
}

// f_LP (LPW0/LPB0 ...) or f_dec (DCW0/DCB0 ...): a chain of layers from first_in to last_out columns.
static plResult plReadLayers( const uint8_t* data, const plSectionTable* table, uint32_t flags, const char* prefix,
							  uint32_t count, uint32_t first_in, uint32_t last_out, plLayer* layers, plAssetData* a )
{
	uint32_t in_count = first_in;
	for ( uint32_t i = 0; i < count; ++i )
	{
		char wname[5] = { prefix[0], prefix[1], 'W', (char)( '0' + i ), 0 };
		char bname[5] = { prefix[0], prefix[1], 'B', (char)( '0' + i ), 0 };
		const plSection* ws = plFindSection( table, wname );
		if ( ws == NULL || ws->rank != 2 || ws->dims[1] != in_count || ws->dims[0] == 0 )
		{
			return plRejectSection( a, wname, "(layer %u's weights) missing, or not [out][%u] after the layer before",
									i, in_count );
		}
		uint32_t out_count = ws->dims[0];
		if ( i + 1 == count && out_count != last_out )
		{
			return plRejectSection( a, wname, "(the last layer's weights) %u outputs, expected %u", out_count,
									last_out );
		}
		// The layer's two sections through the table reader, into the layer, with the layer's own sizes.
		plSectionSpec specs[2] = {
			{ { 0 }, PLEAT_DTYPE_WEIGHTS, 2, { PLEAT_DIM_D, PLEAT_DIM_I, PLEAT_DIM_3 }, PLEAT_SECTION_FINITE,
			  (uint16_t)offsetof( plLayer, weight ), (uint16_t)offsetof( plLayer, weight_fp16 ), "layer weights" },
			{ { 0 }, PLEAT_DTYPE_F32, 1, { PLEAT_DIM_D, PLEAT_DIM_3, PLEAT_DIM_3 }, PLEAT_SECTION_FINITE,
			  (uint16_t)offsetof( plLayer, bias ), 0, "layer bias" } };
		memcpy( specs[0].fourcc, wname, 5 );
		memcpy( specs[1].fourcc, bname, 5 );
		uint32_t sizes[PLEAT_DIM_COUNT] = { 0 };
		sizes[PLEAT_DIM_D] = out_count;
		sizes[PLEAT_DIM_I] = in_count;
		plResult r = ( flags & PLEAT_FLAG_INT8 ) != 0
						 ? plReadInt8Layer( data, table, flags, prefix, i, specs[1], sizes, &layers[i], a )
						 : plReadSections( data, table, flags, specs, 2, sizes, &layers[i], a );
		if ( r != PLEAT_RESULT_OK )
		{
			return r;
		}
		layers[i].in_count = in_count;
		layers[i].out_count = out_count;
		plFindLayerBlocks( &layers[i] ); // a packed ensemble's block-diagonal layers (layer_blocks.c)
		in_count = out_count;
	}
	return PLEAT_RESULT_OK;
}

// The body contact (asset 1.1, optional, all or none; 1.2 adds the candidates BACA and the rings BARG): docs/asset-
// format.md "Body contact".
static plResult plReadBodyContact( const uint8_t* data, const plSectionTable* table, uint32_t flags, plAssetData* a )
{
	int present = 0;
	for ( uint32_t t = 0; t < PLEAT_SPEC_COUNT( s_body_sections ); ++t )
	{
		present += plFindSection( table, s_body_sections[t].fourcc ) != NULL;
	}
	const plSection* baca = plFindSection( table, "BACA" );
	const plSection* barg = plFindSection( table, "BARG" );
	if ( present == 0 )
	{
		return baca == NULL && barg == NULL
				   ? PLEAT_RESULT_OK
				   : plRejectSection( a, baca != NULL ? "BACA" : "BARG", "without the body points (BANC ... BASW)" );
	}
	const plSection* basi = plFindSection( table, "BASI" );
	const plSection* banc = plFindSection( table, "BANC" );
	if ( present != 5 )
	{
		return plRejectSection( a, "BANC", "the body contact needs all of BANC, BASH, BANN, BASI and BASW" );
	}
	if ( basi->rank != 2 || basi->dims[1] < 1 || basi->dims[1] > PLEAT_MAX_INFLUENCES )
	{
		return plRejectSection( a, "BASI", "(body point skin joint indices) not [P][1..%d]", PLEAT_MAX_INFLUENCES );
	}
	if ( banc->rank != 2 )
	{
		return plRejectSection( a, "BANC", "(body points) not [P][3]" );
	}
	uint32_t sizes[PLEAT_DIM_COUNT] = { 0 };
	sizes[PLEAT_DIM_3] = 3;
	sizes[PLEAT_DIM_N] = a->vertex_count;
	sizes[PLEAT_DIM_B] = a->beta_count;
	sizes[PLEAT_DIM_KA] = basi->dims[1];
	sizes[PLEAT_DIM_P] = a->vertex_count; // 1.1: a point per vertex
	sizes[PLEAT_DIM_C] = 1;
	uint32_t N = a->vertex_count;
	if ( baca != NULL )
	{
		if ( baca->rank != 2 || baca->dims[1] < 1 || baca->dims[1] > PLEAT_MAX_CONTACT_CANDIDATES )
		{
			return plRejectSection( a, "BACA", "(contact candidates) not [N][1..%d]", PLEAT_MAX_CONTACT_CANDIDATES );
		}
		if ( banc->dims[0] < 1 || banc->dims[0] >= PLEAT_NO_CONTACT_CANDIDATE )
		{
			return plRejectSection( a, "BANC", "(body points) %u points, expected 1..%u", banc->dims[0],
									PLEAT_NO_CONTACT_CANDIDATE - 1u );
		}
		sizes[PLEAT_DIM_P] = banc->dims[0];
		sizes[PLEAT_DIM_C] = baca->dims[1];
		plResult r = plReadSections( data, table, flags, &s_candidates_section, 1, sizes, a, a );
		if ( r != PLEAT_RESULT_OK )
		{
			return r;
		}
		uint32_t P = sizes[PLEAT_DIM_P];
		for ( uint64_t i = 0; i < (uint64_t)N * sizes[PLEAT_DIM_C]; ++i )
		{
			uint16_t c = a->body_anchor_candidates[i];
			if ( c >= P && c != PLEAT_NO_CONTACT_CANDIDATE )
			{
				return plRejectSection( a, "BACA", "(contact candidates) point %u of %u", c, P );
			}
		}
	}
	uint32_t P = sizes[PLEAT_DIM_P], Ka = sizes[PLEAT_DIM_KA], C = sizes[PLEAT_DIM_C];
	plResult r =
		plReadSections( data, table, flags, s_body_sections, PLEAT_SPEC_COUNT( s_body_sections ), sizes, a, a );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	uint32_t bad = plFirstBadSkinRow( a->body_anchor_skin_indices, a->body_anchor_skin_weights, P, Ka, a->joint_count );
	if ( bad < P )
	{
		return plRejectSection( a, "BASW", "(with BASI) body point %u: weights not finite, negative or not summing to "
										   "1, or a joint index >= J", bad );
	}
	// Each normal is a unit vector (± 1e-3, as pleat-pack writes it) or zero (a point that never anchors).
	for ( uint32_t p = 0; p < P; ++p )
	{
		const float* n = a->body_anchor_normals + (size_t)p * 3;
		double len = sqrt( (double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2] );
		if ( len != 0.0 && fabs( len - 1.0 ) > 1e-3 )
		{
			return plRejectSection( a, "BANN", "(body point normals) point %u has length %g", p, len );
		}
	}
	// BARG (1.2, optional): per point a ring of 3..R point indices < P, then empty entries (or none at all).
	if ( barg != NULL )
	{
		uint32_t R = barg->rank == 2 ? barg->dims[1] : 0;
		if ( R < 3 || R > PLEAT_MAX_POINT_RING )
		{
			return plRejectSection( a, "BARG", "(body point rings) not [P][3..%d]", PLEAT_MAX_POINT_RING );
		}
		sizes[PLEAT_DIM_R] = R;
		r = plReadSections( data, table, flags, &s_rings_section, 1, sizes, a, a );
		if ( r != PLEAT_RESULT_OK )
		{
			return r;
		}
		for ( uint32_t p = 0; p < P; ++p )
		{
			const uint16_t* ring = a->body_anchor_ring + (size_t)p * R;
			uint32_t m = 0;
			while ( m < R && ring[m] < P )
			{
				m++;
			}
			int valid = m == 0 || m >= 3;
			for ( uint32_t i = m; valid && i < R; ++i )
			{
				valid = ring[i] == PLEAT_NO_CONTACT_CANDIDATE; // after the ring only empty entries
			}
			if ( !valid )
			{
				return plRejectSection( a, "BARG", "(body point rings) point %u: a ring of %u, or a point >= P", p, m );
			}
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

// NAME and META: sections of their own shapes.
static plResult plReadNameAndMeta( const uint8_t* data, const plSectionTable* table, plAssetData* a )
{
	const plSection* name = plFindSection( table, "NAME" );
	if ( name == NULL || name->dtype != PLEAT_DTYPE_U8 || name->rank != 1 || name->dims[0] > 64 )
	{
		return plRejectSection( a, "NAME", "(asset name) missing or not u8 [<= 64]" );
	}
	memcpy( a->name, data + name->offset, name->dims[0] );
	a->name[name->dims[0]] = 0;
	if ( memchr( a->name, 0, name->dims[0] ) != NULL )
	{
		return plRejectSection( a, "NAME", "(asset name) holds a NUL" );
	}
	const plSection* meta = plFindSection( table, "META" );
	if ( meta != NULL )
	{
		if ( meta->dtype != PLEAT_DTYPE_U8 || meta->rank != 1 )
		{
			return plRejectSection( a, "META", "(metadata) not u8 [n]" );
		}
		a->meta = (const char*)( data + meta->offset );
		a->meta_size = meta->size;
	}
	return PLEAT_RESULT_OK;
}

// PINS, OXLP and OXDC (optional): sections of their own shapes; the ONNX models checked to reach nothing outside.
static plResult plReadPinsAndModels( const uint8_t* data, const plSectionTable* table, plAssetData* a )
{
	const plSection* pins = plFindSection( table, "PINS" );
	if ( pins != NULL )
	{
		if ( pins->dtype != PLEAT_DTYPE_U32 || pins->rank != 1 )
		{
			return plRejectSection( a, "PINS", "(pinned vertices) not u32 [n]" );
		}
		a->pinned = (const uint32_t*)( data + pins->offset );
		a->pinned_count = pins->dims[0];
		for ( uint32_t i = 0; i < a->pinned_count; ++i )
		{
			if ( a->pinned[i] >= a->vertex_count )
			{
				return plRejectSection( a, "PINS", "(pinned vertices) vertex %u of %u", a->pinned[i], a->vertex_count );
			}
		}
	}
	static const char* const model_names[2] = { "OXLP", "OXDC" };
	const plSection* models[2] = { plFindSection( table, "OXLP" ), plFindSection( table, "OXDC" ) };
	for ( int m = 0; m < 2; ++m )
	{
		if ( models[m] != NULL && ( models[m]->dtype != PLEAT_DTYPE_U8 || models[m]->size == 0 ) )
		{
			return plRejectSection( a, model_names[m], "(ONNX model) empty or not u8" );
		}
	}
	if ( models[0] != NULL )
	{
		a->onnx_lp = data + models[0]->offset;
		a->onnx_lp_size = models[0]->size;
	}
	if ( models[1] != NULL )
	{
		a->onnx_dec = data + models[1]->offset;
		a->onnx_dec_size = models[1]->size;
	}
	// Checked here, whatever backend an instance will use: an asset whose model reaches outside it is not one asset
	// (onnx_model.c), and loading it is where an engine learns that.
	for ( int m = 0; m < 2; ++m )
	{
		plOnnxFinding finding = models[m] != NULL ? plOnnxModel_Check( data + models[m]->offset, models[m]->size )
												  : PLEAT_ONNX_SELF_CONTAINED;
		if ( finding != PLEAT_ONNX_SELF_CONTAINED )
		{
			a->rejected_item =
				finding == PLEAT_ONNX_MALFORMED ? PLEAT_LOG_ASSET_BAD_CONTENT : PLEAT_LOG_ASSET_ONNX_REACHES_OUTSIDE;
			return plRejectSection( a, model_names[m], "%s", plOnnxFinding_Describe( finding ) );
		}
	}
	return PLEAT_RESULT_OK;
}

// The joints (names NUL-terminated and unique, parents before children, root only at 0, input joints ascending past the root),
// the latent bounds, the mesh (face indices, the CSR adjacency) and the skin rows.
static plResult plCheckAcrossSections( plAssetData* a )
{
	uint32_t N = a->vertex_count, F = a->face_count, J = a->joint_count, Jin = a->input_joint_count;
	for ( uint32_t j = 0; j < J; ++j )
	{
		if ( memchr( a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE, 0, PLEAT_JOINT_NAME_SIZE ) == NULL )
		{
			return plRejectSection( a, "JNAM", "(joint names) joint %u's name has no NUL", j );
		}
		// Engines map their joints to the asset's by name (plAsset_FindJoint), and an instance refuses a map that
		// drives two asset joints from one engine joint: a repeated name would make that map impossible to build.
		for ( uint32_t k = 0; k < j; ++k )
		{
			if ( strcmp( a->joint_names + (size_t)k * PLEAT_JOINT_NAME_SIZE,
						 a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE ) == 0 )
			{
				return plRejectSection( a, "JNAM", "(joint names) joints %u and %u are both called '%s'", k, j,
										a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE );
			}
		}
		int32_t p = a->parents[j];
		if ( j == 0 ? p != -1 : ( p < 0 || p >= (int32_t)j ) )
		{
			return plRejectSection( a, "JPAR", "(joint parents) joint %u has parent %d", j, (int)p );
		}
	}
	for ( uint32_t i = 0; i < Jin; ++i )
	{
		uint32_t k = a->input_joints[i];
		if ( k == 0 || k >= J || ( i > 0 && k <= a->input_joints[i - 1] ) )
		{
			return plRejectSection( a, "JINP", "(input joints) entry %u is joint %u", i, k );
		}
	}
	for ( uint32_t i = 0; i < a->latent_count; ++i )
	{
		if ( !( a->z_min[i] <= a->z_max[i] ) )
		{
			return plRejectSection( a, "ZMIN", "(latent lower bound) above ZMAX at %u", i );
		}
	}
	for ( uint64_t i = 0; i < (uint64_t)F * 3; ++i )
	{
		if ( a->faces[i] >= N )
		{
			return plRejectSection( a, "FACE", "(faces) vertex index %u of %u", a->faces[i], N );
		}
	}
	if ( a->adjacency_offsets[0] != 0 || a->adjacency_offsets[N] != 3 * F )
	{
		return plRejectSection( a, "NADO", "(normals adjacency offsets) not from 0 to 3F" );
	}
	for ( uint32_t v = 0; v < N; ++v ) // every range first: a broken offset is NADO's fault, not the faces'
	{
		uint32_t begin = a->adjacency_offsets[v], end = a->adjacency_offsets[v + 1];
		if ( end < begin || end > 3 * F )
		{
			return plRejectSection( a, "NADO", "(normals adjacency offsets) vertex %u's range [%u, %u)", v, begin,
									end );
		}
	}
	for ( uint32_t v = 0; v < N; ++v )
	{
		uint32_t begin = a->adjacency_offsets[v], end = a->adjacency_offsets[v + 1];
		for ( uint32_t e = begin; e < end; ++e )
		{
			uint32_t f = a->adjacency_faces[e];
			if ( f >= F || ( e > begin && f <= a->adjacency_faces[e - 1] ) )
			{
				return plRejectSection( a, "NADF", "(normals adjacency faces) vertex %u: face %u out of range or "
												   "out of order", v, f );
			}
			const uint32_t* tri = a->faces + (size_t)f * 3;
			if ( tri[0] != v && tri[1] != v && tri[2] != v )
			{
				return plRejectSection( a, "NADF", "(normals adjacency faces) vertex %u is not in face %u", v, f );
			}
		}
	}
	uint32_t bad = plFirstBadSkinRow( a->skin_indices, a->skin_weights, N, a->influence_count, J );
	if ( bad < N )
	{
		return plRejectSection( a, "SKNW", "(with SKNI) vertex %u: weights not finite, negative or not summing to 1, "
										   "or a joint index >= J", bad );
	}
	return PLEAT_RESULT_OK;
}

static plResult plReadContent( const uint8_t* data, const plSectionTable* table, uint32_t flags, plAssetData* a )
{
	plResult r = plReadConf( data, table, flags, a );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	uint32_t sizes[PLEAT_DIM_COUNT] = { 0 };
	sizes[PLEAT_DIM_3] = 3;
	sizes[PLEAT_DIM_N] = a->vertex_count;
	sizes[PLEAT_DIM_N_PLUS_1] = a->vertex_count + 1;
	sizes[PLEAT_DIM_F] = a->face_count;
	sizes[PLEAT_DIM_3F] = 3 * a->face_count;
	sizes[PLEAT_DIM_J] = a->joint_count;
	sizes[PLEAT_DIM_JIN] = a->input_joint_count;
	sizes[PLEAT_DIM_K] = a->influence_count;
	sizes[PLEAT_DIM_B] = a->beta_count;
	sizes[PLEAT_DIM_L] = a->latent_count;
	sizes[PLEAT_DIM_I] = a->input_count;
	sizes[PLEAT_DIM_D] = a->blend_count;
	sizes[PLEAT_DIM_NAME] = PLEAT_JOINT_NAME_SIZE;
	sizes[PLEAT_DIM_CONF] = PLEAT_CONF_SIZE;
	r = plReadNameAndMeta( data, table, a );
	r = r == PLEAT_RESULT_OK
			? plReadSections( data, table, flags, s_sections, PLEAT_SPEC_COUNT( s_sections ), sizes, a, a )
			: r;
	if ( r == PLEAT_RESULT_OK && ( flags & PLEAT_FLAG_INT8_BLEND_SHAPES ) != 0 )
	{
		r = plReadSections( data, table, flags, s_int8_blend_sections, PLEAT_SPEC_COUNT( s_int8_blend_sections ),
							sizes, a, a );
		a->blend_shapes.type = PLEAT_SHAPES_I8;
	}
	else if ( r == PLEAT_RESULT_OK )
	{
		r = plReadSections( data, table, flags, s_blend_sections, PLEAT_SPEC_COUNT( s_blend_sections ), sizes, a, a );
	}
	r = r == PLEAT_RESULT_OK ? plCheckAcrossSections( a ) : r;
	r = r == PLEAT_RESULT_OK ? plReadLayers( data, table, flags, "LP", a->lp_layer_count, a->input_count,
											 a->latent_count, a->lp, a )
							 : r;
	r = r == PLEAT_RESULT_OK ? plReadLayers( data, table, flags, "DC", a->dec_layer_count, a->latent_count,
											 a->blend_count, a->dec, a )
							 : r;
	if ( r == PLEAT_RESULT_OK )
	{
		r = plReadBodyContact( data, table, flags, a );
		if ( r != PLEAT_RESULT_OK )
		{
			a->body_anchors = NULL; // all or none
			a->body_anchor_candidates = NULL;
			a->body_anchor_ring = NULL;
		}
	}
	return r == PLEAT_RESULT_OK ? plReadPinsAndModels( data, table, a ) : r;
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
	plResult r = plReadSectionTable( data, size, skip_checksum, &table, &flags, out );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	r = plReadContent( data, &table, flags, out );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	out->block = data;
	out->size = size;
	return PLEAT_RESULT_OK;
}
