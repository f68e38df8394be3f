// pleat-render --crowd N: N characters (bodies of different β, different clips and phases) on a grid that runs away
// from the camera, dressed by one plScene over the garment's tiers under a per-frame budget. Each character's
// importance is its screen coverage (∝ 1 / distance²), so the near ones get the accurate tiers and the far ones the
// cheap tiers or LBS-only; the garments are coloured by the detail they show (legend on every frame). The SDK steps
// every character with the real root motion (the networks see the true velocities); for the picture each character is
// drawn at its grid cell, its root's horizontal travel taken out.
#define _POSIX_C_SOURCE 200809L
#include "render_crowd.h"
#include "render_gl.h"
#include "render_image.h"
#include "render_mesh.h"

#include <pleat/pleat.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#define CROWD_MAX_CHARACTERS 64

typedef struct CrowdCharacter
{
	int body, clip, phase;
	float cell[3];        // where it is drawn (metres)
	int32_t joint_map[PLEAT_MAX_JOINTS];
	RenderMesh* garment;
	RenderMesh* body_mesh;
} CrowdCharacter;

static double crowdNow( void )
{
	struct timespec t;
	clock_gettime( CLOCK_MONOTONIC, &t );
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int crowdFail( const char* what, plResult r )
{
	fprintf( stderr, "render --crowd: %s failed: %s\n", what, plResultString( r ) );
	return 1;
}

// The colour of a detail: tiers from blue (most accurate) through green and orange to red, paler at a reduced network
// rate; LBS-only grey.
static void crowdColour( int32_t tier, float rate_hz, int tier_count, float rgb[3] )
{
	static const float palette[5][3] = {
		{ 0.20f, 0.45f, 0.80f }, { 0.25f, 0.65f, 0.35f }, { 0.90f, 0.60f, 0.15f }, { 0.80f, 0.25f, 0.25f },
		{ 0.60f, 0.30f, 0.70f } };
	if ( tier < 0 )
	{
		rgb[0] = rgb[1] = rgb[2] = 0.55f;
		return;
	}
	int k = tier_count > 1 ? tier * 4 / ( tier_count - 1 ) : 0;
	k = k > 4 ? 4 : k;
	memcpy( rgb, palette[tier < 5 && tier_count <= 5 ? tier : k], sizeof( float ) * 3 );
	for ( int c = 0; rate_hz > 0.0f && c < 3; ++c )
		rgb[c] += 0.45f * ( 1.0f - rgb[c] );
}

int renderCrowd( const CrowdOptions* o )
{
	RenderBody bodies[CROWD_MAX_FILES];
	RenderMotion clips[CROWD_MAX_FILES];
	for ( int b = 0; b < o->body_count; ++b )
	{
		if ( renderBody_Load( &bodies[b], o->body_paths[b] ) != 0 )
			return 1;
	}
	for ( int c = 0; c < o->clip_count; ++c )
	{
		if ( renderMotion_Load( &clips[c], o->clip_paths[c] ) != 0 )
			return 1;
	}
	mkdir( o->out_dir, 0777 );
	RenderGl* gl = renderGl_Create( o->width, o->height );
	if ( gl == NULL )
		return 77;

	plContextDef cdef = plDefaultContextDef();
	plContext context;
	plResult r = plCreateContext( &cdef, &context );
	if ( r != PLEAT_RESULT_OK )
		return crowdFail( "plCreateContext", r );
	plAsset tiers[CROWD_MAX_FILES];
	for ( int t = 0; t < o->tier_count; ++t )
	{
		plAssetDef adef = plDefaultAssetDef();
		adef.path = o->tier_paths[t];
		if ( ( r = plLoadAsset( context, &adef, &tiers[t] ) ) != PLEAT_RESULT_OK )
			return crowdFail( o->tier_paths[t], r );
	}
	plAssetInfo info;
	plAsset_GetInfo( tiers[0], &info );
	const uint32_t* faces;
	uint32_t face_count;
	plAsset_GetFaces( tiers[0], &faces, &face_count );

	const float rates[2] = { clips[0].fps / 2.0f, clips[0].fps / 4.0f }; // the networks every 2nd or 4th frame
	int have_errors = 0;
	for ( int t = 0; t <= o->tier_count; ++t )
		have_errors |= o->tier_errors_mm[t] > 0.0f;
	plSceneDef sdef = plDefaultSceneDef();
	sdef.tiers = tiers;
	sdef.tier_count = (uint32_t)o->tier_count;
	sdef.tier_error_mm = have_errors ? o->tier_errors_mm : NULL;
	sdef.lbs_error_mm = have_errors ? o->tier_errors_mm[o->tier_count] : 0.0f;
	sdef.network_rates_hz = rates;
	sdef.network_rate_count = 2;
	sdef.frame_rate_hz = clips[0].fps;
	sdef.budget_us = o->budget_us;
	sdef.character_capacity = (uint32_t)o->characters;
	plScene scene;
	if ( ( r = plCreateScene( context, &sdef, &scene ) ) != PLEAT_RESULT_OK )
		return crowdFail( "plCreateScene", r );

	// The grid: 8 across, rows running away from the camera.
	CrowdCharacter* crowd = calloc( (size_t)o->characters, sizeof( CrowdCharacter ) );
	int columns = o->characters < 8 ? o->characters : 8;
	int rows = ( o->characters + columns - 1 ) / columns;
	float centre_z = -0.5f * ( rows - 1 ) * 2.4f;
	for ( int i = 0; i < o->characters; ++i )
	{
		CrowdCharacter* ch = &crowd[i];
		ch->body = i % o->body_count;
		ch->clip = ( i / o->body_count + i ) % o->clip_count;
		ch->phase = ( i * 7 ) % (int)clips[ch->clip].frame_count;
		ch->cell[0] = ( (float)( i % columns ) - 0.5f * (float)( columns - 1 ) ) * 1.5f + 0.4f * (float)( ( i / columns ) % 2 );
		ch->cell[2] = -2.4f * (float)( i / columns );
		const RenderMotion* clip = &clips[ch->clip];
		for ( uint32_t k = 0; k < info.joint_count; ++k )
			ch->joint_map[k] = -1;
		for ( uint32_t j = 0; j < clip->joint_count; ++j )
		{
			int32_t k;
			if ( plAsset_FindJoint( tiers[0], clip->joint_names[j], &k ) == PLEAT_RESULT_OK )
				ch->joint_map[k] = (int32_t)j;
		}
		const RenderBody* body = &bodies[ch->body];
		plCharacterDef chdef = plDefaultCharacterDef();
		chdef.joint_map = ch->joint_map;
		chdef.joint_map_count = info.joint_count;
		chdef.engine_joint_count = clip->joint_count;
		chdef.beta = body->beta; // the garment takes the body's own β
		chdef.beta_count = body->beta_count;
		uint32_t id;
		if ( ( r = plScene_AddCharacter( scene, &chdef, &id ) ) < 0 )
			return crowdFail( "plScene_AddCharacter", r );
		ch->garment = renderMesh_Create( gl, info.vertex_count, faces, face_count, 0, 0 );
		ch->body_mesh = renderMesh_Create( gl, body->vertex_count, body->faces, body->face_count, 0, 0 );
	}
	// The body joint → asset joint maps, per body.
	int32_t body_to_asset[CROWD_MAX_FILES][RENDER_MAX_JOINTS];
	for ( int b = 0; b < o->body_count; ++b )
	{
		for ( uint32_t j = 0; j < bodies[b].joint_count; ++j )
		{
			if ( plAsset_FindJoint( tiers[0], bodies[b].joint_names[j], &body_to_asset[b][j] ) != PLEAT_RESULT_OK )
			{
				fprintf( stderr, "render --crowd: body joint %s is not in the asset\n", bodies[b].joint_names[j] );
				return 1;
			}
		}
	}

	RenderCamera camera = { { 0.0f, 3.4f, 6.5f }, { 0.0f, 0.6f, centre_z * 0.7f }, 48.0f };
	plFrameInput inputs[CROWD_MAX_CHARACTERS];
	plResult results[CROWD_MAX_CHARACTERS];
	float skin[PLEAT_MAX_JOINTS * 12];
	uint32_t max_body = 0;
	for ( int b = 0; b < o->body_count; ++b )
		max_body = bodies[b].vertex_count > max_body ? bodies[b].vertex_count : max_body;
	float* body_positions = malloc( (size_t)max_body * 12 );
	float* body_normals = malloc( (size_t)max_body * 12 );
	float* garment_positions = malloc( (size_t)info.vertex_count * 12 );
	RenderImage frame_image, sheet;
	renderImage_Alloc( &frame_image, o->width, o->height );
	int rendered_total = ( o->frames + o->frame_step - 1 ) / o->frame_step;
	int tiles = o->sheet_tiles < rendered_total ? o->sheet_tiles : rendered_total;
	int sheet_columns = tiles < 2 ? tiles : 2, sheet_rows = tiles > 0 ? ( tiles + sheet_columns - 1 ) / sheet_columns : 0;
	int tile_w = o->width / 2, tile_h = o->height / 2;
	if ( tiles > 0 )
	{
		renderImage_Alloc( &sheet, sheet_columns * tile_w, sheet_rows * tile_h );
		memset( sheet.rgb, 255, (size_t)sheet.width * (size_t)sheet.height * 3 );
	}
	double step_ms_sum = 0.0;
	int status = 0, rendered = 0, tile = 0;
	for ( int f = 0; f < o->frames && status == 0; ++f )
	{
		for ( int i = 0; i < o->characters; ++i )
		{
			CrowdCharacter* ch = &crowd[i];
			const RenderMotion* clip = &clips[ch->clip];
			int frame = ( ch->phase + f ) % (int)clip->frame_count;
			const float* data = clip->frames + (size_t)frame * clip->frame_floats;
			const float* root = data + clip->joint_count * 4;
			plFrameInput in = { 0 };
			in.joint_rotations = data;
			in.joint_count = clip->joint_count;
			in.joint_stride_bytes = 16;
			in.root_translation = ( plVec3 ){ root[0], root[1], root[2] };
			in.root_rotation = ( plQuat ){ root[3], root[4], root[5], root[6] };
			in.dt_s = 1.0f / clip->fps;
			inputs[i] = in;
			// Importance: screen coverage, ∝ 1 / distance² from the camera.
			float dx = ch->cell[0] - camera.eye[0], dy = 1.0f - camera.eye[1], dz = ch->cell[2] - camera.eye[2];
			plScene_SetImportance( scene, (uint32_t)i, 10.0f / ( dx * dx + dy * dy + dz * dz ) );
		}
		double t0 = crowdNow();
		r = plScene_Step( scene, inputs, NULL, results, (uint32_t)o->characters );
		step_ms_sum += ( crowdNow() - t0 ) * 1e3;
		if ( r < 0 )
		{
			status = crowdFail( "plScene_Step", r );
			break;
		}
		if ( f % o->frame_step != 0 )
			continue;

		renderGl_BeginFrame( gl, &camera, camera.target );
		int counts[CROWD_MAX_FILES + 1] = { 0 }, fading = 0, reduced = 0;
		for ( int i = 0; i < o->characters; ++i )
		{
			CrowdCharacter* ch = &crowd[i];
			const RenderBody* body = &bodies[ch->body];
			// The root's horizontal travel taken out: the character stays in its cell.
			float offset[3] = { ch->cell[0] - inputs[i].root_translation.x, 0.0f, ch->cell[2] - inputs[i].root_translation.z };
			plScene_GetSkinMatrices( scene, (uint32_t)i, skin, info.joint_count );
			skinBody( body, body_to_asset[ch->body], skin, body_positions );
			for ( uint32_t v = 0; v < body->vertex_count; ++v )
				for ( int k = 0; k < 3; ++k )
					body_positions[v * 3 + k] += offset[k];
			vertexNormals( body_positions, body->vertex_count, body->faces, body->face_count, body_normals );
			renderMesh_Update( ch->body_mesh, body_positions, body_normals );
			const float *positions, *normals;
			plScene_GetPositions( scene, (uint32_t)i, &positions, NULL );
			plScene_GetNormals( scene, (uint32_t)i, &normals, NULL );
			for ( uint32_t v = 0; v < info.vertex_count; ++v )
				for ( int k = 0; k < 3; ++k )
					garment_positions[v * 3 + k] = positions[v * 3 + k] + offset[k];
			renderMesh_Update( ch->garment, garment_positions, normals );
			plDetail detail;
			float fade;
			plScene_GetDetail( scene, (uint32_t)i, &detail, NULL, &fade );
			counts[detail.tier < 0 ? o->tier_count : detail.tier] += 1;
			fading += fade < 1.0f;
			float colour[3];
			static const float body_colour[3] = { 0.80f, 0.77f, 0.73f };
			crowdColour( detail.tier, detail.network_rate_hz, o->tier_count, colour );
			reduced += detail.tier >= 0 && detail.network_rate_hz > 0.0f;
			renderGl_DrawMesh( gl, ch->body_mesh, body_colour, 1.0f );
			renderGl_DrawMesh( gl, ch->garment, colour, 0.55f );
		}
		if ( renderGl_EndFrame( gl, &frame_image ) != 0 )
		{
			status = 1;
			break;
		}
		plScenePlan plan;
		plScene_GetPlan( scene, &plan );
		char line[200];
		if ( o->budget_us > 0.0f )
			snprintf( line, sizeof( line ), "frame %d  %d characters  budget %.0f us  plan %.0f us", f, o->characters,
					  o->budget_us, plan.cost_us );
		else
			snprintf( line, sizeof( line ), "frame %d  %d characters  no budget  plan %.0f us", f, o->characters,
					  plan.cost_us );
		renderImage_DrawText( &frame_image, 8, 8, 2, line );
		int x = 8;
		for ( int t = 0; t <= o->tier_count; ++t )
		{
			if ( t < o->tier_count )
				snprintf( line, sizeof( line ), "tier %d: %d  ", t, counts[t] );
			else
				snprintf( line, sizeof( line ), "LBS: %d  reduced rate: %d  fading: %d", counts[t], reduced, fading );
			renderImage_DrawText( &frame_image, x, o->height - 22, 2, line );
			x += renderImage_TextWidth( line, 2 );
		}
		char path[1024];
		snprintf( path, sizeof( path ), "%s/crowd_%04d.png", o->out_dir, f );
		if ( renderImage_WritePng( &frame_image, path ) != 0 )
		{
			fprintf( stderr, "render --crowd: cannot write %s\n", path );
			status = 1;
			break;
		}
		if ( tile < tiles && ( tiles == 1 ? rendered == 0 : rendered == tile * ( rendered_total - 1 ) / ( tiles - 1 ) ) )
		{
			renderImage_Blit( &sheet, ( tile % sheet_columns ) * tile_w, ( tile / sheet_columns ) * tile_h, tile_w,
							  tile_h, &frame_image );
			++tile;
		}
		++rendered;
	}
	if ( status == 0 && tiles > 0 )
	{
		char path[1024];
		snprintf( path, sizeof( path ), "%s/crowd_sheet.png", o->out_dir );
		status = renderImage_WritePng( &sheet, path ) != 0;
		if ( status == 0 )
			printf( "render --crowd: wrote %s (%d tiles); %d characters, %d frames, plScene_Step mean %.2f ms\n", path,
					tile, o->characters, o->frames, step_ms_sum / o->frames );
	}
	if ( tiles > 0 )
		renderImage_Free( &sheet );
	renderImage_Free( &frame_image );
	for ( int i = 0; i < o->characters; ++i )
	{
		renderMesh_Destroy( crowd[i].garment );
		renderMesh_Destroy( crowd[i].body_mesh );
	}
	free( crowd );
	free( body_positions );
	free( body_normals );
	free( garment_positions );
	plDestroyContext( context );
	renderGl_Destroy( gl );
	for ( int b = 0; b < o->body_count; ++b )
		renderBody_Free( &bodies[b] );
	for ( int c = 0; c < o->clip_count; ++c )
		renderMotion_Free( &clips[c] );
	return status;
}

// ---- options ----

int renderCrowd_Requested( int argc, char** argv )
{
	for ( int i = 1; i < argc; ++i )
	{
		if ( strcmp( argv[i], "--crowd" ) == 0 )
			return 1;
	}
	return 0;
}

// Splits a comma-separated list in place into paths (at most CROWD_MAX_FILES).
static int crowdList( char* text, const char** out )
{
	int count = 0;
	for ( char* p = strtok( text, "," ); p != NULL && count < CROWD_MAX_FILES; p = strtok( NULL, "," ) )
		out[count++] = p;
	return count;
}

static void crowdUsage( void )
{
	fprintf( stderr, "usage: pleat-render --crowd N --tiers T0.pleat,T1.pleat,.. --bodies B0.bin,.. --clips C0.bin,..\n"
					 "                    [--budget-us B] [--tier-errors e0,e1,..,lbs] [--out DIR] [--size WxH]\n"
					 "                    [--frames N] [--step S] [--sheet N]\n" );
}

int renderCrowd_Main( int argc, char** argv )
{
	CrowdOptions o;
	memset( &o, 0, sizeof( o ) );
	o.out_dir = "out/crowd";
	o.width = 960;
	o.height = 540;
	o.frames = 60;
	o.frame_step = 20;
	o.sheet_tiles = 4;
	for ( int i = 1; i + 1 < argc; i += 2 )
	{
		const char* key = argv[i];
		char* value = argv[i + 1];
		if ( strcmp( key, "--crowd" ) == 0 )
			o.characters = atoi( value );
		else if ( strcmp( key, "--tiers" ) == 0 )
			o.tier_count = crowdList( value, o.tier_paths );
		else if ( strcmp( key, "--bodies" ) == 0 )
			o.body_count = crowdList( value, o.body_paths );
		else if ( strcmp( key, "--clips" ) == 0 )
			o.clip_count = crowdList( value, o.clip_paths );
		else if ( strcmp( key, "--budget-us" ) == 0 )
			o.budget_us = strtof( value, NULL );
		else if ( strcmp( key, "--tier-errors" ) == 0 )
		{
			int n = 0;
			for ( char* p = strtok( value, "," ); p != NULL && n <= CROWD_MAX_FILES; p = strtok( NULL, "," ) )
				o.tier_errors_mm[n++] = strtof( p, NULL );
		}
		else if ( strcmp( key, "--out" ) == 0 )
			o.out_dir = value;
		else if ( strcmp( key, "--size" ) == 0 )
		{
			if ( sscanf( value, "%dx%d", &o.width, &o.height ) != 2 || o.width < 64 || o.height < 64 )
				o.width = 0;
		}
		else if ( strcmp( key, "--frames" ) == 0 )
			o.frames = atoi( value );
		else if ( strcmp( key, "--step" ) == 0 )
			o.frame_step = atoi( value );
		else if ( strcmp( key, "--sheet" ) == 0 )
			o.sheet_tiles = atoi( value );
		else
		{
			fprintf( stderr, "render --crowd: unknown option %s\n", key );
			crowdUsage();
			return 2;
		}
	}
	if ( o.characters < 1 || o.characters > CROWD_MAX_CHARACTERS || o.tier_count < 1 || o.body_count < 1 ||
		 o.clip_count < 1 || o.width == 0 || o.frames < 1 || o.frame_step < 1 || o.sheet_tiles < 0 ||
		 !( o.budget_us >= 0.0f ) )
	{
		crowdUsage();
		return 2;
	}
	return renderCrowd( &o );
}
