// Stand-in for the GL compute path (sdk/src/backends/gl/) when it is absent or PLEAT_GL is off.
#include "gl_deformer.h"

plResult plGlDeformer_Create( const plGlDeformerDesc* desc, const plAllocator* allocator, plGlDeformer** out )
{
	(void)desc;
	(void)allocator;
	if ( out != NULL )
	{
		*out = NULL;
	}
	return PLEAT_RESULT_GL_UNAVAILABLE;
}

plResult plGlDeformer_SetShapedTemplate( plGlDeformer* deformer, const float* shaped_template, const float* body_anchors )
{
	(void)deformer;
	(void)shaped_template;
	(void)body_anchors;
	return PLEAT_RESULT_GL_UNAVAILABLE;
}

plResult plGlDeformer_SetBodyContact( plGlDeformer* deformer, int enabled, float offset_m )
{
	(void)deformer;
	(void)enabled;
	(void)offset_m;
	return PLEAT_RESULT_GL_UNAVAILABLE;
}

plResult plGlDeformer_Run( plGlDeformer* deformer, const float* blend_weights, const float* skin_matrices,
						   float* positions, float* normals )
{
	(void)deformer;
	(void)blend_weights;
	(void)skin_matrices;
	(void)positions;
	(void)normals;
	return PLEAT_RESULT_GL_UNAVAILABLE;
}

void plGlDeformer_Destroy( plGlDeformer* deformer )
{
	(void)deformer;
}

_Atomic uint64_t g_plGlDispatches;

int plGlDeformer_HasNetworks( const plGlDeformer* deformer )
{
	(void)deformer;
	return 0;
}

int plGlDeformer_CanBatch( const plGlDeformer* lead, const plGlDeformer* member )
{
	(void)lead;
	(void)member;
	return 0;
}

plResult plGlDeformer_RunBatch( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count )
{
	(void)lead;
	(void)members;
	(void)count;
	return PLEAT_RESULT_GL_UNAVAILABLE;
}
