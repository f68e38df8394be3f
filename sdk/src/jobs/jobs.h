// Internal: the runtime's jobs, one file each, mirroring the paper (docs/inputs.md "Network evaluation"). A job is a
// struct of input and output spans with _Validate (non-zero = valid) and _Run (validates, never allocates). Jobs see
// only spans, the kernel table and the task runner: never a context, an asset or an instance, so they sit below all
// three (docs/architecture.md).
#ifndef PLEAT_JOBS_H
#define PLEAT_JOBS_H
#include "kernels/kernels.h"
#include "pleat/pleat.h"
#include "core/tasks.h"

#include <stddef.h>
#include <stdint.h>

// A strided array: count elements, stride_bytes apart, inside [ptr, ptr + bytes).
typedef struct plSpan
{
	void* ptr;
	size_t bytes;
	uint32_t count;
	uint32_t stride_bytes;
} plSpan;

typedef struct plConstSpan
{
	const void* ptr;
	size_t bytes;
	uint32_t count;
	uint32_t stride_bytes;
} plConstSpan;

// Non-zero if the span holds at least required_count elements of element_bytes (4-byte aligned floats).
int plSpan_Holds( const void* ptr, size_t bytes, uint32_t count, uint32_t stride_bytes, uint32_t element_bytes,
				  uint32_t required_count );
#define PLEAT_SPAN_HOLDS( span, element_bytes, required )                                                             \
	plSpan_Holds( ( span ).ptr, ( span ).bytes, ( span ).count, ( span ).stride_bytes, element_bytes, required )
plSpan plMakeSpan( void* ptr, uint32_t count, uint32_t stride_bytes );
plConstSpan plMakeConstSpan( const void* ptr, uint32_t count, uint32_t stride_bytes );
// Non-zero if input and output are packed float spans of the same, non-zero count: an element-wise job's spans.
int plSpan_ElementwiseFloats( const plConstSpan* input, const plSpan* output );

// Non-zero if none of the count floats is NaN or ±inf: the step's guards (a non-finite value inside a step is a
// numeric reset) and the loader's content checks. Branch-free so the compiler vectorises the N·3 scans of a step.
int plAllFiniteFloats( const float* v, size_t count );

// ---- network_rate.c: whether a step runs the networks, and their dt (docs/inputs.md "Network update rate") ----
// Not a job (no spans): the one decision plInstance_Step makes before anything runs, kept apart so that the numpy
// twin (tools/pleat/reference/network_rate.py) can mirror it line for line.

typedef struct plNetworkUpdate
{
	int run;        // the networks run on this step (else the held deformation is skinned with the new pose)
	double dt_s;    // run: all the time since the networks' last update, clamped; else the step's own dt_s (seconds)
	int dt_clamped; // run, and dt_s was clamped to the asset's [dt_min_s, dt_max_s]
} plNetworkUpdate;

// network_interval_s: 1 / network_rate_hz (0 = every step); network_pending_s: time gathered since the last update;
// dt_s: this step's dt (validated, in (0, 1]); first_frame: no history yet (the networks always run then).
plNetworkUpdate plDecideNetworkUpdate( double network_interval_s, double network_pending_s, float dt_s, int first_frame,
									   float dt_min_s, float dt_max_s );

// ---- shape_blend.c: the shape blend G_S(β) — T + Σ_b β_b G_S[b] — and the joints J(β) it moves ----
// Run once per β (creation, plInstance_SetShape), not per step; both accumulate in double in b order.

typedef struct plShapeBlendJob
{
	plConstSpan template_positions;  // [N] xyz, packed (stride 12): T, metres
	const float* shape_blend_shapes; // [B][N][3] G_S, metres per unit β
	plConstSpan beta;                // [B] floats, packed, clamped
	plSpan output;                   // [N] xyz, packed (stride 12): T + G_S(β)
} plShapeBlendJob;

int plShapeBlendJob_Validate( const plShapeBlendJob* job );
plResult plShapeBlendJob_Run( const plShapeBlendJob* job );

typedef struct plShapedJointsJob
{
	const float* joint_template;  // [J][3] metres
	const float* joint_shapedirs; // [B][J][3] metres per unit β
	uint32_t joint_count;         // J
	plConstSpan beta;             // [B] floats, packed, clamped
	double* output;               // [J][3] J(β), metres: the rest joints of forward kinematics
} plShapedJointsJob;

int plShapedJointsJob_Validate( const plShapedJointsJob* job );
plResult plShapedJointsJob_Run( const plShapedJointsJob* job );

// ---- forward_kinematics.c: one frame of pose → joint transforms, heading yaw and skinning matrices ----

// One frame of the pose history, in double precision (small; X_c is assembled from it).
typedef struct plPoseFrame
{
	double local_rotations[PLEAT_MAX_JOINTS][9]; // R_k, row-major 3×3
	double joint_positions[PLEAT_MAX_JOINTS][3]; // p_k = translation of G_k (metres)
	double pelvis_rotation[9];                   // P = Q_root · R_0
	double yaw;                                  // heading yaw about +Y (radians)
	double dt_s;                                 // time from the previous pose (seconds, clamped)
} plPoseFrame;

typedef struct plForwardKinematicsJob
{
	const int32_t* parents;           // [J]
	uint32_t joint_count;             // J
	const double* rest_joints;        // [J][3] J(β), metres
	const double* root_translation;   // [3] metres
	const double* root_rotation;      // [9] row-major
	double previous_yaw;              // used when the pelvis forward axis is vertical
	double dt_s;
	plPoseFrame* frame;               // in: local_rotations; out: joint_positions, pelvis_rotation, yaw, dt_s
	float* skin_matrices;             // out, optional: [J][3][4] row-major M_k = G_k · T(−J_k)
} plForwardKinematicsJob;

int plForwardKinematicsJob_Validate( const plForwardKinematicsJob* job );
plResult plForwardKinematicsJob_Run( const plForwardKinematicsJob* job );

// Quaternion (x, y, z, w), unit length → row-major 3×3 (rotations.py quat_to_matrix).
void plQuatToMatrix( const double q[4], double m[9] );

// ---- input_assembly.c: X_c exactly per docs/inputs.md ----

// I = L + 8 + 3·(6·Jin + 6) + 9·Jin + B + 4, the length of X_c (docs/inputs.md); the loader checks CONF against it.
uint64_t plInputCountFormula( uint64_t latent_count, uint64_t input_joint_count, uint64_t beta_count );

typedef struct plInputAssemblyJob
{
	const plPoseFrame* frames[3];      // t+1, t, t−1
	const float* latent;               // [latent_count] Z_t
	uint32_t latent_count;
	const uint32_t* input_joints;      // [input_joint_count]
	uint32_t input_joint_count;
	const float* beta;                 // [beta_count], clamped
	uint32_t beta_count;
	const float* material_normalized;  // [4] in [0, 1]
	plSpan output;                     // [I] floats, packed
} plInputAssemblyJob;

int plInputAssemblyJob_Validate( const plInputAssemblyJob* job );
plResult plInputAssemblyJob_Run( const plInputAssemblyJob* job );

// ---- input_normalisation.c: x = (X_c − x_mean) / x_std, what f_LP reads (the training statistics of X_c) ----

typedef struct plInputNormalisationJob
{
	plConstSpan input;   // [I] floats, packed: X_c
	const float* x_mean; // [I]
	const float* x_std;  // [I], each > 0 (the loader checks)
	plSpan output;       // [I] floats, packed; may be input itself
} plInputNormalisationJob;

int plInputNormalisationJob_Validate( const plInputNormalisationJob* job );
plResult plInputNormalisationJob_Run( const plInputNormalisationJob* job );

// ---- mlp.c: a chain of Linear layers, activation on hidden layers, last layer linear ----

typedef struct plMlpJob
{
	const plLayer* layers;
	uint32_t layer_count;
	uint32_t activation;        // PLEAT_ACTIVATION_RELU or _SILU
	plConstSpan input;          // [layers[0].in_count] floats, packed
	plSpan output;              // [layers[last].out_count] floats, packed
	plSpan scratch;             // [2 · widest hidden layer] floats, packed, 32-byte aligned
	const plKernels* kernels;
	const plTaskRunner* runner; // optional: rows are split over workers
} plMlpJob;

int plMlpJob_Validate( const plMlpJob* job );
plResult plMlpJob_Run( const plMlpJob* job );

// ---- latent_guard.c: Z_t+1 = clamp(y · z_std + z_mean, z_min, z_max), the latent kept in its training range ----

typedef struct plLatentGuardJob
{
	plConstSpan input;   // [L] floats, packed: y, f_LP's standardised output. The step checks it is finite first:
	                     // the clamp would turn ±inf into a bound and hide an overflow that must reset the instance
	const float* z_mean; // [L]
	const float* z_std;  // [L]
	const float* z_min;  // [L] latent units
	const float* z_max;  // [L]
	plSpan output;       // [L] floats, packed: Z_t+1
} plLatentGuardJob;

int plLatentGuardJob_Validate( const plLatentGuardJob* job );
plResult plLatentGuardJob_Run( const plLatentGuardJob* job );

// ---- blend_shapes.c: T_def = shaped template + Σ_j w_j D_j over a vertex range ----

typedef struct plBlendShapesJob
{
	plConstSpan shaped_template; // [N] xyz, packed (stride 12), metres
	plBlendShapes blend_shapes;  // [D][N][3] fp32, fp16 or int8
	plConstSpan weights;         // [D] floats, packed; for int8 shapes with their scales folded in (plFoldShapeScales)
	plSpan output;               // [N] xyz, packed (stride 12)
	uint32_t vertex_begin, vertex_end;
	const plKernels* kernels;
} plBlendShapesJob;

int plBlendShapesJob_Validate( const plBlendShapesJob* job );
plResult plBlendShapesJob_Run( const plBlendShapesJob* job );

// ---- skinning.c: x' = Σ_k w_k M_{j_k} x over a vertex range (strided spans) ----

typedef struct plSkinningJob
{
	plConstSpan positions;     // [N] xyz, any stride
	const uint16_t* skin_indices; // [N][K]
	const float* skin_weights;    // [N][K]
	uint32_t influence_count;     // K
	const float* skin_matrices;   // [J][3][4]
	uint32_t joint_count;         // J
	plSpan output;             // [N] xyz, any stride (may not alias positions)
	uint32_t vertex_begin, vertex_end;
	const plKernels* kernels;     // optional: NULL = the scalar kernel
	const uint32_t* column_offsets; // optional: plSkinColumnOffsets of skin_indices, for the AVX2 kernel
} plSkinningJob;

int plSkinningJob_Validate( const plSkinningJob* job );
plResult plSkinningJob_Run( const plSkinningJob* job );

// ---- body_contact.c: pose the body points, then keep skinned vertices outside the tangent plane of the nearest of their
// candidate points (pleat.h, BODY CONTACT)

typedef struct plBodyPointsJob
{
	const float* shaped_points;        // [P][3] rest body points of this β (r + Σ_b β_b BASH[b])
	const float* point_normals;        // [P][3] rest unit normals, zero = never an anchor
	const uint16_t* skin_indices;      // [P][Ka]
	const float* skin_weights;         // [P][Ka]
	uint32_t influence_count;          // Ka
	const float* skin_matrices;        // [J][3][4], the skinning job's
	uint32_t joint_count;              // J
	float* posed;                      // out: [P][PLEAT_POSED_POINT_FLOATS] (kernels.h)
	uint32_t point_count;              // P
	uint32_t point_begin, point_end;
	const plKernels* kernels;          // optional: NULL = the scalar kernel
	const uint16_t* rings;             // optional: [P][R] (BARG): the points whose normals plBodyPointNormalsJob sets
	uint32_t ring_count;               // R, with rings
	const uint32_t* column_offsets;    // optional: plSkinColumnOffsets of skin_indices, for the AVX2 kernel
} plBodyPointsJob;

int plBodyPointsJob_Validate( const plBodyPointsJob* job );
plResult plBodyPointsJob_Run( const plBodyPointsJob* job );

typedef struct plBodyPointNormalsJob
{
	float* posed;                      // [P][PLEAT_POSED_POINT_FLOATS], every position posed (plBodyPointsJob)
	uint32_t point_count;              // P
	const uint16_t* rings;             // [P][R] (BARG)
	uint32_t ring_count;               // R
	uint32_t point_begin, point_end;
	const plKernels* kernels;          // optional: NULL = the scalar kernel
	const int32_t* ring_lanes;         // optional: the rings in lanes (plRingLanes), for the AVX2 kernel
} plBodyPointNormalsJob;

plResult plBodyPointNormalsJob_Run( const plBodyPointNormalsJob* job );

typedef struct plBodyContactJob
{
	plSpan positions;                  // [N] xyz, skinned, moved in place, any stride
	const float* posed;                // [P][PLEAT_POSED_POINT_FLOATS] from plBodyPointsJob, this pose
	uint32_t point_count;              // P
	const uint16_t* candidates;        // [N][C] point indices (PLEAT_NO_CONTACT_CANDIDATE = empty); NULL: vertex v's is v
	uint32_t candidate_count;          // C (1 with candidates NULL)
	float offset_m;                    // clearance (metres, >= 0)
	uint32_t vertex_begin, vertex_end;
	const plKernels* kernels;          // optional: NULL = the scalar kernel
	const uint32_t* row_offsets;       // optional: plContactRowOffsets of the candidates, for the AVX2 kernel (posed
									   // then has a zero row P)
} plBodyContactJob;

int plBodyContactJob_Validate( const plBodyContactJob* job );
plResult plBodyContactJob_Run( const plBodyContactJob* job );

// The fast contact (body_contact_fast.c): per vertex its own point, the turned rest normal.
typedef struct plBodyContactFastJob
{
	plSpan positions;                  // [N] xyz, skinned, moved in place, any stride
	const float* shaped_anchors;       // [N][3] rest anchors of this β (a + Σ_b β_b BASH[b])
	const float* anchor_normals;       // [N][3] rest unit normals, zero = no anchor
	const uint16_t* anchor_skin_indices; // [N][Ka]
	const float* anchor_skin_weights;    // [N][Ka]
	uint32_t influence_count;          // Ka
	const float* skin_matrices;        // [J][3][4], the skinning job's
	uint32_t joint_count;              // J
	float offset_m;                    // clearance (metres, >= 0)
	uint32_t vertex_begin, vertex_end;
	const plKernels* kernels;          // optional: NULL = the scalar kernel
	const uint32_t* column_offsets;    // optional: plSkinColumnOffsets of anchor_skin_indices, for the AVX2 kernel
} plBodyContactFastJob;

int plBodyContactFastJob_Validate( const plBodyContactFastJob* job );
plResult plBodyContactFastJob_Run( const plBodyContactFastJob* job );

// ---- normals.c: area-weighted vertex normals n_i = normalize(Σ_{faces f ∋ i} cross(x_b − x_a, x_c − x_a)) ----
// Two algorithms, each with one name on all three sides (C job, GLSL shader, numpy function, same argument names):
//   face normals + normals gather   plFaceNormalsJob + plNormalsGatherJob, shaders/face_normals.comp +
//                                   shaders/normals_gather.comp, reference.normals.face_normals + normals_gather:
//                                   each face's cross product once, then per vertex the sum over its CSR adjacency
//                                   (NADO/NADF) in ascending face order. Splittable over workers, no atomics.
//   normals scatter                 plNormalsScatterJob, reference.normals.normals_scatter: one serial pass adding each
//                                   face to its three vertices in ascending face order. Bit-identical to the above on a
//                                   valid asset (each vertex's adjacency = its faces in ascending order), cheaper on one
//                                   thread, not splittable (no GLSL twin: a GPU would need atomics).
// A vertex whose sum has zero length gets a zero normal (never NaN).

typedef struct plFaceNormalsJob
{
	plConstSpan positions;     // [N] xyz, any stride
	const uint32_t* faces;     // [F][3]
	uint32_t face_count;       // F
	float* face_normals;       // out: [F][4] unnormalised (x, y, z, 0), 16-byte rows: a SIMD kernel loads one per face
	uint32_t face_begin, face_end;
	const plKernels* kernels;  // optional: NULL = the scalar kernel
} plFaceNormalsJob;

int plFaceNormalsJob_Validate( const plFaceNormalsJob* job );
plResult plFaceNormalsJob_Run( const plFaceNormalsJob* job );

typedef struct plNormalsGatherJob
{
	const float* face_normals;         // [F][4] from plFaceNormalsJob
	uint32_t face_count;               // F
	const uint32_t* adjacency_offsets; // [N + 1]
	const uint32_t* adjacency_faces;   // [3F]
	plSpan normals;                    // out: [N] xyz unit normals, any stride
	uint32_t vertex_begin, vertex_end;
	const plKernels* kernels;          // optional: NULL = the scalar kernel
} plNormalsGatherJob;

int plNormalsGatherJob_Validate( const plNormalsGatherJob* job );
plResult plNormalsGatherJob_Run( const plNormalsGatherJob* job );

typedef struct plNormalsScatterJob
{
	plConstSpan positions;    // [N] xyz, any stride
	const uint32_t* faces;    // [F][3]
	uint32_t face_count;      // F
	plSpan normals;           // out: [N] xyz unit normals, any stride
	float* sums4;             // [sums4_count][4] scratch, 16-byte aligned, sums4_count >= N
	uint32_t sums4_count;
	const plKernels* kernels; // optional: NULL = the scalar kernel
} plNormalsScatterJob;

int plNormalsScatterJob_Validate( const plNormalsScatterJob* job );
plResult plNormalsScatterJob_Run( const plNormalsScatterJob* job );

#endif
