// Timing program (not a test): GL compute path vs CPU path on the shipped garment size, on whatever GL the machine
// has (Mesa llvmpipe here). Prints medians; docs/gpu.md records the numbers.
//
//   pleat_gl_step_timing [--frames N] [--crowd 1,8,64] [ASSET.pleat]
//
// 1. Deformation only, on the 4,424-vertex test mesh (tests/c/test_gl_support.c) with D = 128 blend shapes, K = 4,
//    J = 24: the CPU jobs (blend_shapes.c, skinning.c, normals.c through the context's kernel choice, one thread) vs
//    plGlDeformer_Run in headless mode with positions and normals read back (the read-back makes the GL time include
//    the GPU work; without it Run only queues commands).
// 2. With an asset: plInstance_Step with gpu_mode PLEAT_GPU_MODE_NONE vs PLEAT_GPU_MODE_HEADLESS over the same motion, stepped
//    alternately, plus the largest CPU/GL output difference.
// 3. With an asset and --crowd 1,8,64: per count n, three crowds of n instances of the asset, stepped
//    alternately frame by frame on the same motion (each instance its own phase): plStepInstances on headless GPU
//    instances (networks batched on the CPU, one dispatch per shader for the group), plInstance_Step one by one on
//    headless GPU instances, and plStepInstances on CPU instances (one worker). Per-instance medians. The GPU crowds
//    read back only their last instance's positions and normals, which waits for all the frame's GPU work (an engine
//    would draw from the GPU buffers instead); the CPU crowd writes every instance's outputs. Also the largest
//    differences (position m, normal) between the GL batch's last instance and the other two crowds'.
#include "jobs.h"
#include "gl/gl_internal.h"
#include "test_gl_support.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int plCompareDoubles( const void* a, const void* b )
{
	double x = *(const double*)a, y = *(const double*)b;
	return ( x > y ) - ( x < y );
}

static double plMedian( double* values, uint32_t count )
{
	qsort( values, count, sizeof( double ), plCompareDoubles );
	return count % 2 ? values[count / 2] : 0.5 * ( values[count / 2 - 1] + values[count / 2] );
}

// The CPU jobs on one thread, normals as face normals + gather: the algorithm the GL path runs (face_normals.comp,
// normals_gather.comp). face_normals: [F][4] scratch.
static void plCpuDeform( const plTestMesh* mesh, const plKernels* kernels, const float* weights, const float* matrices,
						 float* deformed, float* positions, float* face_normals, float* normals )
{
	uint32_t n = mesh->vertex_count;
	plBlendShapesJob blend = {
		plMakeConstSpan( mesh->shaped_template, n, 12 ), { mesh->blend_shapes, PLEAT_SHAPES_F32, NULL },
		plMakeConstSpan( weights, mesh->blend_count, 4 ), plMakeSpan( deformed, n, 12 ), 0, n, kernels,
	};
	plSkinningJob skin = {
		plMakeConstSpan( deformed, n, 12 ), mesh->skin_indices, mesh->skin_weights, mesh->influence_count, matrices,
		mesh->joint_count, plMakeSpan( positions, n, 12 ), 0, n, kernels, NULL,
	};
	plFaceNormalsJob face = {
		plMakeConstSpan( positions, n, 12 ), mesh->faces, mesh->face_count, face_normals, 0, mesh->face_count, kernels,
	};
	plNormalsGatherJob gather = {
		face_normals, mesh->face_count, mesh->adjacency_offsets, mesh->adjacency_faces, plMakeSpan( normals, n, 12 ),
		0,            n,                kernels,
	};
	if ( plBlendShapesJob_Run( &blend ) != PLEAT_RESULT_OK || plSkinningJob_Run( &skin ) != PLEAT_RESULT_OK ||
		 plFaceNormalsJob_Run( &face ) != PLEAT_RESULT_OK || plNormalsGatherJob_Run( &gather ) != PLEAT_RESULT_OK )
	{
		fprintf( stderr, "CPU job failed\n" );
		exit( 1 );
	}
}

static double plMaxDiff( const float* a, const float* b, size_t count )
{
	double worst = 0.0;
	for ( size_t i = 0; i < count; ++i )
		worst = fmax( worst, fabs( (double)a[i] - (double)b[i] ) );
	return worst;
}

static int plTimeDeformation( uint32_t frames )
{
	plTestMesh mesh;
	plTestMesh_Build( &mesh, 79, 56, 128, 3 );
	uint32_t n = mesh.vertex_count;
	plTestAllocatorState allocator_state;
	plAllocator allocator = plTestAllocator( &allocator_state );
	plGlDeformerDesc desc;
	memset( &desc, 0, sizeof( desc ) );
	desc.mode = PLEAT_GL_DEFORMER_HEADLESS;
	desc.vertex_count = n;
	desc.face_count = mesh.face_count;
	desc.blend_count = mesh.blend_count;
	desc.influence_count = mesh.influence_count;
	desc.joint_count = mesh.joint_count;
	desc.shaped_template = mesh.shaped_template;
	desc.blend_shapes = ( plBlendShapes ){ mesh.blend_shapes, PLEAT_SHAPES_F32, NULL };
	desc.skin_indices = mesh.skin_indices;
	desc.skin_weights = mesh.skin_weights;
	desc.faces = mesh.faces;
	desc.adjacency_offsets = mesh.adjacency_offsets;
	desc.adjacency_faces = mesh.adjacency_faces;
	plGlDeformer* deformer = NULL;
	plResult result = plGlDeformer_Create( &desc, &allocator, &deformer );
	if ( result != PLEAT_RESULT_OK )
	{
		printf( "deformation: GL deformer unavailable (plResult %d)\n", (int)result );
		plTestMesh_Free( &mesh );
		return 1;
	}
	plKernels kernels;
	int avx2 = plChooseKernels( &kernels, PLEAT_KERNEL_SET_AVX512 ) != PLEAT_KERNEL_SET_SCALAR;
	float* weights = malloc( sizeof( float ) * mesh.blend_count );
	float* matrices = malloc( sizeof( float ) * 12 * mesh.joint_count );
	float* buffers = malloc( sizeof( float ) * 3 * n * 5 );
	float *deformed = buffers, *cpu_positions = buffers + 3 * n, *cpu_normals = buffers + 6 * n;
	float *gl_positions = buffers + 9 * n, *gl_normals = buffers + 12 * n;
	float* face_normals = malloc( sizeof( float ) * 4 * mesh.face_count );
	double* cpu_s = malloc( sizeof( double ) * frames );
	double* gl_s = malloc( sizeof( double ) * frames );
	double worst_position = 0.0, worst_normal = 0.0;
	for ( uint32_t warm = 0; warm < 10; ++warm )
		plGlDeformer_Run( deformer, weights, matrices, gl_positions, gl_normals );
	for ( uint32_t frame = 0; frame < frames; ++frame )
	{
		plTestMotion_Frame( &mesh, frame, weights, matrices );
		double t0 = plTestNowSeconds();
		plCpuDeform( &mesh, &kernels, weights, matrices, deformed, cpu_positions, face_normals, cpu_normals );
		double t1 = plTestNowSeconds();
		if ( plGlDeformer_Run( deformer, weights, matrices, gl_positions, gl_normals ) != PLEAT_RESULT_OK )
		{
			fprintf( stderr, "plGlDeformer_Run failed\n" );
			return 1;
		}
		double t2 = plTestNowSeconds();
		cpu_s[frame] = t1 - t0;
		gl_s[frame] = t2 - t1;
		worst_position = fmax( worst_position, plMaxDiff( cpu_positions, gl_positions, 3 * (size_t)n ) );
		worst_normal = fmax( worst_normal, plMaxDiff( cpu_normals, gl_normals, 3 * (size_t)n ) );
	}
	printf( "deformation only (N = %u, D = %u, K = %u, J = %u, %u frames, median):\n", n, mesh.blend_count,
			mesh.influence_count, mesh.joint_count, frames );
	printf( "  cpu_deform_us %.1f (%s kernels, 1 thread)\n", 1e6 * plMedian( cpu_s, frames ),
			avx2 ? "AVX2" : "scalar" );
	printf( "  gl_deform_us  %.1f (headless, read-back of positions + normals)\n", 1e6 * plMedian( gl_s, frames ) );
	printf( "  max |cpu - gl| position %.3g m, normal %.3g\n", worst_position, worst_normal );
	plGlDeformer_Destroy( deformer );
	free( weights );
	free( matrices );
	free( buffers );
	free( face_normals );
	free( cpu_s );
	free( gl_s );
	plTestMesh_Free( &mesh );
	return 0;
}

#ifndef PLEAT_GL_TIMING_NO_INSTANCE // (set only by scratch builds without instance.c)
// A smooth swing of every joint about a per-joint axis, ±0.4 rad, and a walking root; phase shifts the swing (one per
// crowd member). rotations: [4 joint_count], filled here and referenced by the input.
static plFrameInput plSwingFrame( uint32_t frame, double phase, float* rotations, uint32_t joint_count )
{
	double t = frame / 30.0;
	for ( uint32_t k = 0; k < joint_count; ++k )
	{
		double angle = 0.4 * sin( 2.0 * t + 0.5 * k + phase ), ax = cos( 0.7 * k ), az = sin( 0.7 * k );
		double s = sin( 0.5 * angle );
		rotations[4 * k] = (float)( s * ax );
		rotations[4 * k + 1] = 0.0f;
		rotations[4 * k + 2] = (float)( s * az );
		rotations[4 * k + 3] = (float)cos( 0.5 * angle );
	}
	plFrameInput input;
	memset( &input, 0, sizeof( input ) );
	input.joint_rotations = rotations;
	input.joint_count = joint_count;
	input.root_translation = ( plVec3 ){ 0.0f, 0.0f, (float)( 1.2 * t ) };
	input.root_rotation = ( plQuat ){ 0.0f, 0.0f, 0.0f, 1.0f };
	input.dt_s = 1.0f / 30.0f;
	return input;
}

// A default context with the asset at path loaded; 0 (and a message) if either fails.
static int plOpenAsset( const char* path, plContext* context, plAsset* asset, plAssetInfo* info )
{
	plContextDef context_def = plDefaultContextDef();
	plAssetDef asset_def = plDefaultAssetDef();
	asset_def.path = path;
	if ( plCreateContext( &context_def, context ) != PLEAT_RESULT_OK ||
		 plLoadAsset( *context, &asset_def, asset ) != PLEAT_RESULT_OK || plAsset_GetInfo( *asset, info ) != PLEAT_RESULT_OK )
	{
		fprintf( stderr, "cannot load %s\n", path );
		return 0;
	}
	return 1;
}

static int plTimeInstances( const char* path, uint32_t frames )
{
	plContext context;
	plAsset asset;
	plAssetInfo info;
	if ( !plOpenAsset( path, &context, &asset, &info ) )
		return 1;
	plInstance instances[2];
	for ( int i = 0; i < 2; ++i )
	{
		plInstanceDef def = plDefaultInstanceDef();
		def.asset = asset;
		def.gpu_mode = i == 0 ? PLEAT_GPU_MODE_NONE : PLEAT_GPU_MODE_HEADLESS;
		plResult result = plCreateInstance( context, &def, &instances[i] );
		if ( result != PLEAT_RESULT_OK )
		{
			printf( "instance (%s): %s\n", i == 0 ? "cpu" : "gl", plResultString( result ) );
			return 1;
		}
	}
	uint32_t n = info.vertex_count, j = info.joint_count;
	float* rotations = malloc( sizeof( float ) * 4 * j );
	float* outputs = malloc( sizeof( float ) * 12 * n );
	double* step_s[2] = { malloc( sizeof( double ) * frames ), malloc( sizeof( double ) * frames ) };
	double worst_position = 0.0, worst_normal = 0.0;
	for ( uint32_t frame = 0; frame < frames; ++frame )
	{
		plFrameInput input = plSwingFrame( frame, 0.0, rotations, j );
		for ( int i = 0; i < 2; ++i )
		{
			plStepOutput output = { outputs + 6 * n * i, 0, outputs + 6 * n * i + 3 * n, 0, n };
			double t0 = plTestNowSeconds();
			plResult result = plInstance_Step( instances[i], &input, &output );
			step_s[i][frame] = plTestNowSeconds() - t0;
			if ( result < 0 )
			{
				printf( "step (%s): %s\n", i == 0 ? "cpu" : "gl", plResultString( result ) );
				return 1;
			}
		}
		worst_position = fmax( worst_position, plMaxDiff( outputs, outputs + 6 * n, 3 * (size_t)n ) );
		worst_normal = fmax( worst_normal, plMaxDiff( outputs + 3 * n, outputs + 9 * n, 3 * (size_t)n ) );
	}
	printf( "plInstance_Step on %s (N = %u, D = %u, L = %u, %u frames, median):\n", path, n, info.blend_count,
			info.latent_count, frames );
	printf( "  cpu_step_us %.1f\n", 1e6 * plMedian( step_s[0], frames ) );
	printf( "  gl_step_us  %.1f (headless, outputs read back)\n", 1e6 * plMedian( step_s[1], frames ) );
	printf( "  max |cpu - gl| position %.3g m, normal %.3g\n", worst_position, worst_normal );
	plDestroyInstance( instances[0] );
	plDestroyInstance( instances[1] );
	plDestroyAsset( asset );
	plDestroyContext( context );
	free( rotations );
	free( outputs );
	free( step_s[0] );
	free( step_s[1] );
	return 0;
}

enum
{
	PL_CROWD_GL_BATCH,
	PL_CROWD_GL_ONE_BY_ONE,
	PL_CROWD_CPU_BATCH,
	PL_CROWD_KINDS
};

// One count of the crowd timing (3. in the header); prints one JSON line.
static int plTimeCrowd( plContext context, plAsset asset, const plAssetInfo* info, uint32_t count, uint32_t frames )
{
	static const char* names[PL_CROWD_KINDS] = { "gl_batch", "gl_one_by_one", "cpu_batch" };
	uint32_t n = info->vertex_count, j = info->joint_count;
	plInstance* instances = calloc( (size_t)PL_CROWD_KINDS * count, sizeof( plInstance ) );
	plFrameInput* inputs = calloc( count, sizeof( plFrameInput ) );
	plStepOutput* outputs = calloc( (size_t)PL_CROWD_KINDS * count, sizeof( plStepOutput ) );
	float* rotations = malloc( sizeof( float ) * 4 * j * count );
	float* last = malloc( sizeof( float ) * 6 * n * PL_CROWD_KINDS ); // the last instance's positions, normals
	float* cpu_out = malloc( sizeof( float ) * 6 * n * count );
	double* seconds = malloc( sizeof( double ) * frames * PL_CROWD_KINDS );
	int status = 1;
	uint32_t created = 0; // instances[0, created) exist
	if ( !instances || !inputs || !outputs || !rotations || !last || !cpu_out || !seconds )
		goto done;
	for ( uint32_t kind = 0; kind < PL_CROWD_KINDS; ++kind )
		for ( uint32_t i = 0; i < count; ++i )
		{
			plInstanceDef def = plDefaultInstanceDef();
			def.asset = asset;
			def.gpu_mode = kind == PL_CROWD_CPU_BATCH ? PLEAT_GPU_MODE_NONE : PLEAT_GPU_MODE_HEADLESS;
			plResult result = plCreateInstance( context, &def, &instances[kind * count + i] );
			if ( result != PLEAT_RESULT_OK )
			{
				printf( "crowd %u (%s): %s\n", count, names[kind], plResultString( result ) );
				goto done;
			}
			++created;
			plStepOutput* o = &outputs[kind * count + i];
			memset( o, 0, sizeof( *o ) );
			o->vertex_capacity = n;
			if ( kind == PL_CROWD_CPU_BATCH )
			{
				o->positions = cpu_out + 6 * (size_t)n * i;
				o->normals = cpu_out + 6 * (size_t)n * i + 3 * n;
			}
			if ( i + 1 == count )
			{
				o->positions = last + 6 * (size_t)n * kind;
				o->normals = last + 6 * (size_t)n * kind + 3 * n;
			}
		}
	double worst_position[PL_CROWD_KINDS] = { 0.0 }, worst_normal[PL_CROWD_KINDS] = { 0.0 }; // against the GL batch
	const uint32_t warmup = 10;
	for ( uint32_t frame = 0; frame < frames + warmup; ++frame )
	{
		for ( uint32_t i = 0; i < count; ++i )
			inputs[i] = plSwingFrame( frame, 0.37 * i, rotations + 4 * (size_t)j * i, j );
		for ( uint32_t kind = 0; kind < PL_CROWD_KINDS; ++kind )
		{
			const plInstance* set = instances + kind * count;
			const plStepOutput* out = outputs + kind * count;
			double t0 = plTestNowSeconds();
			plResult result = PLEAT_RESULT_OK;
			if ( kind == PL_CROWD_GL_ONE_BY_ONE )
				for ( uint32_t i = 0; i < count && result >= 0; ++i )
					result = plInstance_Step( set[i], &inputs[i], &out[i] );
			else
				result = plStepInstances( context, set, inputs, out, NULL, count );
			double elapsed = plTestNowSeconds() - t0;
			if ( result < 0 )
			{
				printf( "crowd %u (%s): %s\n", count, names[kind], plResultString( result ) );
				goto done;
			}
			if ( frame >= warmup )
				seconds[kind * frames + frame - warmup] = elapsed / count;
		}
		for ( uint32_t kind = 1; kind < PL_CROWD_KINDS; ++kind )
		{
			const float* other = last + 6 * (size_t)n * kind;
			worst_position[kind] = fmax( worst_position[kind], plMaxDiff( last, other, 3 * (size_t)n ) );
			worst_normal[kind] = fmax( worst_normal[kind], plMaxDiff( last + 3 * n, other + 3 * n, 3 * (size_t)n ) );
		}
	}
	printf( "{\"instances\": %u, \"vertices\": %u", count, n );
	for ( uint32_t kind = 0; kind < PL_CROWD_KINDS; ++kind )
		printf( ", \"%s_us_per_instance\": %.2f", names[kind], 1e6 * plMedian( seconds + kind * frames, frames ) );
	for ( uint32_t kind = 1; kind < PL_CROWD_KINDS; ++kind )
		printf( ", \"gl_batch_vs_%s_max_diff\": [%.3g, %.3g]", names[kind], worst_position[kind], worst_normal[kind] );
	printf( "}\n" );
	status = 0;
done:
	for ( uint32_t k = 0; k < created; ++k )
		plDestroyInstance( instances[k] );
	free( instances );
	free( inputs );
	free( outputs );
	free( rotations );
	free( last );
	free( cpu_out );
	free( seconds );
	return status;
}

static int plTimeCrowds( const char* path, const char* counts, uint32_t frames )
{
	plContext context;
	plAsset asset;
	plAssetInfo info;
	if ( !plOpenAsset( path, &context, &asset, &info ) )
		return 1;
	printf( "crowds of %s (per instance, median over %u frames; the CPU crowd on one worker):\n", path, frames );
	int status = 0;
	for ( const char* p = counts; *p != '\0'; )
	{
		char* end = NULL;
		uint32_t count = (uint32_t)strtoul( p, &end, 10 );
		if ( end == p )
			break;
		if ( count > 0 )
			status |= plTimeCrowd( context, asset, &info, count, frames );
		p = *end == ',' ? end + 1 : end;
	}
	plDestroyAsset( asset );
	plDestroyContext( context );
	return status;
}
#else
static int plTimeInstances( const char* path, uint32_t frames )
{
	printf( "instance timing not built (%s, %u frames)\n", path, frames );
	return 1;
}

static int plTimeCrowds( const char* path, const char* counts, uint32_t frames )
{
	printf( "crowd timing not built (%s, %s, %u frames)\n", path, counts, frames );
	return 1;
}
#endif

int main( int argc, char** argv )
{
	uint32_t frames = 300;
	const char* asset = NULL;
	const char* crowd = NULL;
	for ( int i = 1; i < argc; ++i )
	{
		if ( strcmp( argv[i], "--frames" ) == 0 && i + 1 < argc )
			frames = (uint32_t)strtoul( argv[++i], NULL, 10 );
		else if ( strcmp( argv[i], "--crowd" ) == 0 && i + 1 < argc )
			crowd = argv[++i];
		else
			asset = argv[i];
	}
	if ( frames == 0 )
		frames = 1;
	int status = plTimeDeformation( frames );
	if ( asset != NULL )
		status |= plTimeInstances( asset, frames );
	if ( asset != NULL && crowd != NULL )
		status |= plTimeCrowds( asset, crowd, frames );
	return status;
}
