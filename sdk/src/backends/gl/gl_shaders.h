// The GLSL sources of shaders/*.comp, embedded at build time by embed_shaders.cmake (NUL-terminated).
#ifndef PLEAT_GL_SHADERS_H
#define PLEAT_GL_SHADERS_H

extern const char plGlShaderSource_blend_shapes[];
extern const char plGlShaderSource_skinning[];
extern const char plGlShaderSource_face_normals[];
extern const char plGlShaderSource_normals_gather[];
extern const char plGlShaderSource_body_contact[];
extern const char plGlShaderSource_mlp_layer[];
extern const char plGlShaderSource_latent_guard[];

#endif
