// pleat-render: drives a body and a Pleat garment through a mocap clip and writes PNG frames and a contact sheet,
// rendered headless (EGL surfaceless, GL 3.3+ core, MSAA framebuffer, glReadPixels).
//
//     pleat-render --asset assets/tshirt.pleat --body out/demo/body.bin --clip out/demo/walk.bin --out out/demo
//                  [--beta b0,b1,...] [--material m,mu,lambda,k] [--size 640x480] [--frames A:B[:step]]
//                  [--path cpu|gl] [--sheet N]
//     pleat-render --crowd N --tiers T0.pleat,.. --bodies B0.bin,.. --clips C0.bin,.. [--budget-us B] ...
//                  (render_crowd.c: N characters dressed by one plScene under a budget)
//
// The body file (PLBODY01) and the clip file (PLMOTION) are written by `python -m pleat.render_export`; their
// formats are in docs/demo.md. Exit status: 0 = done, 1 = failed, 2 = bad options, 77 = no usable GL (no EGL
// surfaceless context, or the SDK's GL path is unavailable with --path gl), so tests can skip. Every clip frame from A to B is stepped (the garment's dynamics need each one); every
// step-th frame is rendered. The body is skinned here with the instance's own skinning matrices
// (plInstance_GetSkinMatrices), so body and garment always share one skeleton.
#define _POSIX_C_SOURCE 200809L
#include "render_crowd.h"
#include "render_files.h"
#include "render_gl.h"
#include "render_image.h"
#include "render_mesh.h"

#include <pleat/pleat.h>

#include <epoxy/gl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

typedef struct Options
{
	const char* asset_path;
	const char* body_path;
	const char* clip_path;
	const char* out_dir;
	float beta[PLEAT_MAX_BETAS];
	int beta_count; // -1 = use the body file's β
	float material[4];
	int has_material;
	int width, height;
	int frame_begin, frame_end, frame_step; // frame_end -1 = clip end
	int use_gl;
	int sheet_tiles;
} Options;

static void usage( void )
{
	fprintf( stderr, "usage: pleat-render --asset A.pleat --body BODY.bin --clip CLIP.bin [--out DIR]\n"
					 "                    [--beta b0,b1,..] [--material m,mu,lambda,k] [--size WxH]\n"
					 "                    [--frames A:B[:step]] [--path cpu|gl] [--sheet N]\n" );
}

static int parseFloats( const char* text, float* values, int capacity )
{
	int count = 0;
	char* end = NULL;
	while ( *text != '\0' && count < capacity )
	{
		values[count++] = strtof( text, &end );
		if ( end == text )
		{
			return -1;
		}
		text = *end == ',' ? end + 1 : end;
	}
	return *text == '\0' ? count : -1;
}

static int parseOptions( int argc, char** argv, Options* o )
{
	memset( o, 0, sizeof( *o ) );
	o->out_dir = "out/render";
	o->beta_count = -1;
	o->width = 640;
	o->height = 480;
	o->frame_end = -1;
	o->frame_step = 1;
	o->sheet_tiles = 8;
	for ( int i = 1; i < argc; ++i )
	{
		const char* key = argv[i];
		const char* value = i + 1 < argc ? argv[i + 1] : NULL;
		if ( value == NULL )
		{
			fprintf( stderr, "render: %s needs a value\n", key );
			return -1;
		}
		++i;
		if ( strcmp( key, "--asset" ) == 0 )
			o->asset_path = value;
		else if ( strcmp( key, "--body" ) == 0 )
			o->body_path = value;
		else if ( strcmp( key, "--clip" ) == 0 )
			o->clip_path = value;
		else if ( strcmp( key, "--out" ) == 0 )
			o->out_dir = value;
		else if ( strcmp( key, "--beta" ) == 0 )
		{
			if ( ( o->beta_count = parseFloats( value, o->beta, PLEAT_MAX_BETAS ) ) < 0 )
				return -1;
		}
		else if ( strcmp( key, "--material" ) == 0 )
		{
			if ( parseFloats( value, o->material, 4 ) != 4 )
				return -1;
			o->has_material = 1;
		}
		else if ( strcmp( key, "--size" ) == 0 )
		{
			if ( sscanf( value, "%dx%d", &o->width, &o->height ) != 2 || o->width < 64 || o->height < 64 ||
				 o->width > 8192 || o->height > 8192 )
				return -1;
		}
		else if ( strcmp( key, "--frames" ) == 0 )
		{
			int n = sscanf( value, "%d:%d:%d", &o->frame_begin, &o->frame_end, &o->frame_step );
			if ( n < 2 || o->frame_begin < 0 || o->frame_end <= o->frame_begin || o->frame_step < 1 )
				return -1;
		}
		else if ( strcmp( key, "--path" ) == 0 )
		{
			if ( strcmp( value, "cpu" ) != 0 && strcmp( value, "gl" ) != 0 )
				return -1;
			o->use_gl = strcmp( value, "gl" ) == 0;
		}
		else if ( strcmp( key, "--sheet" ) == 0 )
		{
			o->sheet_tiles = atoi( value );
			if ( o->sheet_tiles < 0 || o->sheet_tiles > 64 )
				return -1;
		}
		else
		{
			fprintf( stderr, "render: unknown option %s\n", key );
			return -1;
		}
	}
	return o->asset_path != NULL && o->body_path != NULL && o->clip_path != NULL ? 0 : -1;
}

static double nowSeconds( void )
{
	struct timespec t;
	clock_gettime( CLOCK_MONOTONIC, &t );
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

// The "model" string of the asset's META JSON, if any (a plain scan: META is written by pleat tools).
static void metaModel( const plAssetInfo* info, char* out, size_t capacity )
{
	out[0] = '\0';
	if ( info->meta_json == NULL )
		return;
	char* meta = malloc( info->meta_json_size + 1 );
	if ( meta == NULL )
		return;
	memcpy( meta, info->meta_json, info->meta_json_size );
	meta[info->meta_json_size] = '\0';
	const char* key = strstr( meta, "\"model\"" );
	const char* open = key != NULL ? strchr( key + 7, '"' ) : NULL;
	const char* close = open != NULL ? strchr( open + 1, '"' ) : NULL;
	if ( close != NULL )
	{
		size_t n = (size_t)( close - open - 1 ) < capacity - 1 ? (size_t)( close - open - 1 ) : capacity - 1;
		memcpy( out, open + 1, n );
		out[n] = '\0';
	}
	free( meta );
}

static int compareDoubles( const void* a, const void* b )
{
	double x = *(const double*)a, y = *(const double*)b;
	return ( x > y ) - ( x < y );
}

static int fail( const char* what, plResult result )
{
	fprintf( stderr, "render: %s failed: %s\n", what, plResultString( result ) );
	return 1;
}

int main( int argc, char** argv )
{
	if ( renderCrowd_Requested( argc, argv ) )
		return renderCrowd_Main( argc, argv ); // many characters under a budget (render_crowd.c)
	Options o;
	if ( parseOptions( argc, argv, &o ) != 0 )
	{
		usage();
		return 2;
	}
	RenderBody body;
	RenderMotion motion;
	if ( renderBody_Load( &body, o.body_path ) != 0 || renderMotion_Load( &motion, o.clip_path ) != 0 )
		return 1;
	int frame_end = o.frame_end < 0 || o.frame_end > (int)motion.frame_count ? (int)motion.frame_count : o.frame_end;
	if ( o.frame_begin >= frame_end )
	{
		fprintf( stderr, "render: --frames selects nothing (clip has %u frames)\n", motion.frame_count );
		return 2;
	}
	mkdir( o.out_dir, 0777 ); // may exist already; a later write fails loudly if it cannot be made

	// The GL context first: in --path gl the SDK runs its compute shaders inside it (host-context mode).
	RenderGl* gl = renderGl_Create( o.width, o.height );
	if ( gl == NULL )
		return 77;

	plContextDef cdef = plDefaultContextDef();
	plContext context;
	plResult r = plCreateContext( &cdef, &context );
	if ( r != PLEAT_RESULT_OK )
		return fail( "plCreateContext", r );
	plAssetDef adef = plDefaultAssetDef();
	adef.path = o.asset_path;
	plAsset asset;
	if ( ( r = plLoadAsset( context, &adef, &asset ) ) != PLEAT_RESULT_OK )
		return fail( "plLoadAsset", r );
	plAssetInfo info;
	plAsset_GetInfo( asset, &info );
	uint32_t garment_face_count = 0;
	const uint32_t* garment_faces = NULL; // the asset's own FACE section, valid while the asset lives
	if ( ( r = plAsset_GetFaces( asset, &garment_faces, &garment_face_count ) ) != PLEAT_RESULT_OK )
		return fail( "plAsset_GetFaces", r );

	// Joint maps by name: clip joints → asset joints (for the SDK), body joints → asset joints (for body skinning).
	int32_t joint_map[PLEAT_MAX_JOINTS], body_to_asset[RENDER_MAX_JOINTS];
	for ( uint32_t k = 0; k < info.joint_count; ++k )
		joint_map[k] = -1;
	for ( uint32_t j = 0; j < motion.joint_count; ++j )
	{
		int32_t k;
		if ( plAsset_FindJoint( asset, motion.joint_names[j], &k ) == PLEAT_RESULT_OK )
			joint_map[k] = (int32_t)j;
	}
	for ( uint32_t b = 0; b < body.joint_count; ++b )
	{
		if ( ( r = plAsset_FindJoint( asset, body.joint_names[b], &body_to_asset[b] ) ) != PLEAT_RESULT_OK )
		{
			fprintf( stderr, "render: body joint %s is not in the asset\n", body.joint_names[b] );
			return 1;
		}
	}

	int beta_count = o.beta_count >= 0 ? o.beta_count : (int)body.beta_count;
	const float* beta = o.beta_count >= 0 ? o.beta : body.beta;
	for ( int b = 0; b < beta_count && b < (int)body.beta_count; ++b )
		if ( fabsf( beta[b] - body.beta[b] ) > 1e-4f )
			fprintf( stderr, "render: note: --beta differs from the body file's beta; the body mesh keeps its own shape "
							 "(export it again with the same --beta)\n" );

	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = asset;
	idef.joint_map = joint_map;
	idef.joint_map_count = info.joint_count;
	idef.engine_joint_count = motion.joint_count;
	idef.beta = beta;
	idef.beta_count = (uint32_t)( beta_count < (int)info.beta_count ? beta_count : (int)info.beta_count );
	idef.material = o.has_material ? o.material : NULL;
	uint32_t garment_position_buffer = 0, garment_normal_buffer = 0;
	if ( o.use_gl )
	{
		if ( renderGl_Version( gl ) >= 43 )
		{
			// Zero-copy: the SDK's compute shaders write the vertex buffers this renderer draws from.
			idef.gpu_mode = PLEAT_GPU_MODE_HOST_CONTEXT;
			garment_position_buffer = renderGl_CreateVec4Buffer( gl, info.vertex_count );
			garment_normal_buffer = renderGl_CreateVec4Buffer( gl, info.vertex_count );
			idef.host_position_buffer = garment_position_buffer;
			idef.host_normal_buffer = garment_normal_buffer;
		}
		else
			idef.gpu_mode = PLEAT_GPU_MODE_HEADLESS;
	}
	plInstance instance;
	if ( ( r = plCreateInstance( context, &idef, &instance ) ) != PLEAT_RESULT_OK )
	{
		fail( "plCreateInstance", r );
		return r == PLEAT_RESULT_GL_UNAVAILABLE ? 77 : 1;
	}

	RenderMesh* garment_mesh = renderMesh_Create( gl, info.vertex_count, garment_faces, garment_face_count,
												  garment_position_buffer, garment_normal_buffer );
	RenderMesh* body_mesh = renderMesh_Create( gl, body.vertex_count, body.faces, body.face_count, 0, 0 );
	float* body_positions = malloc( (size_t)body.vertex_count * 3 * sizeof( float ) );
	float* body_normals = malloc( (size_t)body.vertex_count * 3 * sizeof( float ) );
	float skin[PLEAT_MAX_JOINTS * 12];
	RenderImage frame_image, sheet;
	renderImage_Alloc( &frame_image, o.width, o.height );

	int rendered_total = ( frame_end - o.frame_begin + o.frame_step - 1 ) / o.frame_step;
	int tiles = o.sheet_tiles < rendered_total ? o.sheet_tiles : rendered_total;
	int columns = tiles < 4 ? tiles : 4, rows = tiles > 0 ? ( tiles + columns - 1 ) / columns : 0;
	int tile_w = o.width / 2, tile_h = o.height / 2;
	if ( tiles > 0 )
	{
		renderImage_Alloc( &sheet, columns * tile_w, rows * tile_h );
		memset( sheet.rgb, 255, (size_t)sheet.width * (size_t)sheet.height * 3 );
	}
	char model[96];
	metaModel( &info, model, sizeof( model ) );
	int pelvis_body = -1;
	for ( uint32_t b = 0; b < body.joint_count; ++b )
		if ( body_to_asset[b] == 0 )
			pelvis_body = (int)b;

	double* step_ms = malloc( sizeof( double ) * (size_t)( frame_end - o.frame_begin ) );
	int step_count = 0, rendered = 0, tile = 0, status = 0;
	float camera_yaw = 0.0f, camera_height = 1.0f;
	const float dt_s = 1.0f / motion.fps;
	for ( int f = o.frame_begin; f < frame_end && status == 0; ++f )
	{
		const float* frame = motion.frames + (size_t)f * motion.frame_floats;
		const float* root = frame + motion.joint_count * 4;
		plFrameInput in = { 0 };
		in.joint_rotations = frame;
		in.joint_count = motion.joint_count;
		in.joint_stride_bytes = 16;
		in.root_translation = ( plVec3 ){ root[0], root[1], root[2] };
		in.root_rotation = ( plQuat ){ root[3], root[4], root[5], root[6] };
		in.dt_s = dt_s;
		double t0 = nowSeconds();
		r = plInstance_Step( instance, &in, NULL );
		double t1 = nowSeconds();
		if ( r < 0 )
		{
			status = fail( "plInstance_Step", r );
			break;
		}
		step_ms[step_count++] = ( t1 - t0 ) * 1e3;

		// The camera follows the pelvis p_0 = G_0 · 0 = M_0 · J_0 over the ground and turns after the character's
		// heading (the yaw of R·(0,0,1), R the rotation of M_0) with a 0.6 s time constant, staying 35° off the
		// facing direction, so a turning walk is still seen from the front-side. Updated on every stepped frame so
		// the motion does not depend on which frames are rendered.
		plInstance_GetSkinMatrices( instance, skin, info.joint_count );
		const float* m0 = skin;
		const float* j0 = body.joints + ( pelvis_body >= 0 ? pelvis_body : 0 ) * 3;
		float pelvis[3];
		for ( int i = 0; i < 3; ++i )
			pelvis[i] = m0[i * 4] * j0[0] + m0[i * 4 + 1] * j0[1] + m0[i * 4 + 2] * j0[2] + m0[i * 4 + 3];
		const float camera_offset = 35.0f * 3.14159265f / 180.0f;
		float wanted_yaw = atan2f( m0[2], m0[10] ) + camera_offset;
		if ( step_count == 1 )
		{
			camera_yaw = wanted_yaw;
			camera_height = pelvis[1] > 0.3f ? pelvis[1] * 0.92f : 0.9f;
		}
		else
		{
			float delta = remainderf( wanted_yaw - camera_yaw, 2.0f * 3.14159265f );
			camera_yaw += delta * ( 1.0f - expf( -dt_s / 0.6f ) );
		}
		if ( ( f - o.frame_begin ) % o.frame_step != 0 )
			continue;

		skinBody( &body, body_to_asset, skin, body_positions );
		vertexNormals( body_positions, body.vertex_count, body.faces, body.face_count, body_normals );
		renderMesh_Update( body_mesh, body_positions, body_normals );
		if ( garment_position_buffer != 0 )
			glMemoryBarrier( GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT );
		else
		{
			const float *positions, *normals;
			uint32_t n;
			plInstance_GetPositions( instance, &positions, &n );
			plInstance_GetNormals( instance, &normals, &n );
			renderMesh_Update( garment_mesh, positions, normals );
		}

		const float distance = 4.2f, pitch = 0.12f;
		RenderCamera camera = { { 0 }, { pelvis[0], camera_height, pelvis[2] }, 30.0f };
		camera.eye[0] = pelvis[0] + distance * sinf( camera_yaw ) * cosf( pitch );
		camera.eye[1] = camera_height + distance * sinf( pitch );
		camera.eye[2] = pelvis[2] + distance * cosf( camera_yaw ) * cosf( pitch );

		static const float body_color[3] = { 0.80f, 0.77f, 0.73f };
		static const float garment_color[3] = { 0.20f, 0.45f, 0.72f };
		renderGl_BeginFrame( gl, &camera, pelvis );
		renderGl_DrawMesh( gl, body_mesh, body_color, 1.0f );
		renderGl_DrawMesh( gl, garment_mesh, garment_color, 0.55f );
		if ( renderGl_EndFrame( gl, &frame_image ) != 0 )
		{
			status = 1;
			break;
		}
		char line[160];
		snprintf( line, sizeof( line ), "frame %d  step %.3f ms  %s", f, step_ms[step_count - 1],
				  o.use_gl ? "gl" : "cpu" );
		renderImage_DrawText( &frame_image, 8, 8, 2, line );
		snprintf( line, sizeof( line ), "%s%s%s", info.name, model[0] ? " - " : "", model );
		renderImage_DrawText( &frame_image, 8, o.height - 22, 2, line );
		char path[1024];
		snprintf( path, sizeof( path ), "%s/frame_%04d.png", o.out_dir, f );
		if ( renderImage_WritePng( &frame_image, path ) != 0 )
		{
			fprintf( stderr, "render: cannot write %s\n", path );
			status = 1;
			break;
		}
		// Tiles are spread evenly over the rendered frames.
		if ( tile < tiles && ( tiles == 1 ? rendered == 0 : rendered == tile * ( rendered_total - 1 ) / ( tiles - 1 ) ) )
		{
			renderImage_Blit( &sheet, ( tile % columns ) * tile_w, ( tile / columns ) * tile_h, tile_w, tile_h,
							  &frame_image );
			++tile;
		}
		++rendered;
	}

	if ( status == 0 && tiles > 0 )
	{
		char path[1024];
		snprintf( path, sizeof( path ), "%s/contact_sheet.png", o.out_dir );
		if ( renderImage_WritePng( &sheet, path ) != 0 )
			status = 1;
		else
			printf( "render: wrote %s (%d tiles)\n", path, tile );
	}
	if ( step_count > 0 )
	{
		qsort( step_ms, (size_t)step_count, sizeof( double ), compareDoubles );
		printf( "render: %d steps (%s path, N = %u, L = %u, D = %u), %d frames written to %s; step median %.3f ms, "
				"max %.3f ms\n",
				step_count, o.use_gl ? "gl" : "cpu", info.vertex_count, info.latent_count, info.blend_count, rendered,
				o.out_dir, step_ms[step_count / 2], step_ms[step_count - 1] );
	}

	free( step_ms );
	if ( tiles > 0 )
		renderImage_Free( &sheet );
	renderImage_Free( &frame_image );
	free( body_positions );
	free( body_normals );
	plDestroyInstance( instance ); // before the GL objects it writes into
	renderMesh_Destroy( garment_mesh );
	renderMesh_Destroy( body_mesh );
	if ( garment_position_buffer != 0 )
	{
		renderGl_DeleteBuffer( gl, garment_position_buffer );
		renderGl_DeleteBuffer( gl, garment_normal_buffer );
	}
	plDestroyAsset( asset );
	plDestroyContext( context );
	renderGl_Destroy( gl );
	renderBody_Free( &body );
	renderMotion_Free( &motion );
	return status;
}
