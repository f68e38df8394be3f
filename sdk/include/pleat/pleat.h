// pleat.h — Pleat runtime SDK: real-time neural cloth for game engines (C11, also compiles as C++).
//
// ==================================================================================================================
// OVERVIEW
// ==================================================================================================================
// Pleat dresses a character with a garment whose deformation (wrinkles, swing, lag) is predicted by two small MLPs
// and a set of learned blend shapes, following "neural cloth with a compact latent" (see docs/ and the paper):
//
//     X_c   = assembled inputs (previous latent, root velocities, 3 frames of rotations and joint positions, β, material)
//     Z_t+1 = clamp(f_LP(normalised X_c))           latent predictor, the latent guard clamps to the training range
//     w     = f_dec(Z_t+1)                          decoder → D blend weights
//     T_def = T + G_S(β) + Σ_j w_j D_j              shaped template (cached per β) + learned blend shapes
//     x'    = Σ_k skin_weight · M_k · T_def         linear blend skinning with the body's joints
//     n     = normalize(Σ area-weighted face normals)
//
// Objects: a context (allocator, task system, log, CPU kernel choice) owns assets (one loaded .pleat file each) and
// instances (one dressed character each: pose history, latent, output buffers). Many instances may share an asset.
//
// ==================================================================================================================
// STEP BY STEP
// ==================================================================================================================
//     plContextDef cdef = plDefaultContextDef();          // change fields in place; zero fields mean "default"
//     plContext context;
//     if ( plCreateContext( &cdef, &context ) != PLEAT_RESULT_OK ) ...
//
//     plAssetDef adef = plDefaultAssetDef();
//     adef.path = "tshirt.pleat";                         // or adef.data / adef.size for a block in memory
//     plAsset asset;
//     plResult r = plLoadAsset( context, &adef, &asset ); // plResultString( r ) names any failure
//     plAssetInfo info; plAsset_GetInfo( asset, &info );  // N vertices, F faces, joints, ...
//     const uint32_t* faces; uint32_t face_count;         // the index buffer: [F][3] vertex indices, read in place
//     plAsset_GetFaces( asset, &faces, &face_count );
//
//     plInstanceDef idef = plDefaultInstanceDef();
//     idef.asset = asset;
//     idef.joint_map = my_map;                            // my_map[asset joint] = engine joint index, -1 = identity
//     idef.joint_map_count = info.joint_count;            // (build it with plAsset_FindJoint)
//     idef.engine_joint_count = my_skeleton_joint_count;
//     plInstance instance;
//     plCreateInstance( context, &idef, &instance );
//
//     each frame:                                         // local rotations relative to the asset's rest pose
//         plFrameInput in = { 0 };                        // (next section: retarget if your bind pose differs)
//         in.joint_rotations = pose; in.joint_count = my_skeleton_joint_count; in.joint_stride_bytes = 16;
//         in.root_translation = ...; in.root_rotation = ...; in.dt_s = 1.0f / 60.0f;
//         plStepOutput out = { 0 };                       // optional: strided destination spans
//         out.positions = vbo_ptr; out.position_stride_bytes = 32; out.normals = vbo_ptr + 3; ...
//         r = plInstance_Step( instance, &in, &out );     // r >= 0: success (maybe with a note), r < 0: nothing changed
//
//     plDestroyInstance( instance ); plDestroyAsset( asset ); plDestroyContext( context );
//
// ==================================================================================================================
// FRAME CONVENTION (docs/inputs.md is the single definition)
// ==================================================================================================================
// Metres, seconds, kilograms; right-handed, +Y up; quaternions (x, y, z, w), unit length (inputs whose length is within
// 1e-3 of one are renormalised, others are rejected with PLEAT_RESULT_INVALID_QUATERNION).
// The pose passed to plInstance_Step is frame t+1: the garment returned by that call is dressed on that pose. dt_s is
// the time from the previous pose to this one. The instance keeps the two previous poses and the previous latent; the
// first step after creation or plInstance_Reset treats the history as standing still with a zero latent.
// Outputs are in the space of the root motion (world space when the engine passes world root motion).
//
// ==================================================================================================================
// SKELETON AND REST POSE (docs/inputs.md, "Retargeting from another bind pose"; docs/body.md)
// ==================================================================================================================
// The joint rotations plInstance_Step takes are LOCAL rotations (each joint relative to its parent) MEASURED FROM THE
// ASSET'S REST POSE: all identity (with an identity root rotation and zero root translation) dresses the garment on
// that rest pose, whatever the engine's own bind pose is. The shipped body's rest pose is a wide A-pose: arms 25°
// below the horizontal in the frontal plane, forearms straight on the same line, legs straight, +Y up, facing +Z, the
// body's left at +X, the mean body's pelvis at the origin. The SDK cannot tell a pose measured from another bind pose
// (a T-pose, or joint frames that are not world-aligned): such input is valid quaternions and gives wrong cloth with no
// error, so an engine whose bind pose differs retargets each frame. plAsset_GetRestPose (mean body, β = 0) and
// plInstance_GetRestPose (the instance's current β) give what a retarget needs, in the form of an engine reference
// pose: per joint the parent, the rest position J(β), the local translation and the local rotation (identity for
// every joint: rest-relative rotations make the rest pose identity by definition). samples/minimal builds a retarget
// from a T-pose engine skeleton with them (samples/minimal/retarget.c): per joint the rotation that takes the asset's
// rest bone directions onto the engine's bind bone directions, applied around the engine's pose.
//
// ==================================================================================================================
// UPDATE RATE (docs/inputs.md, "Network update rate")
// ==================================================================================================================
// With plInstanceDef.network_rate_hz = r > 0 a step runs input assembly, f_LP and f_dec only when the time gathered
// since the last network update (this step's dt included) reaches 1/r, and then with that whole time as the network's
// dt, so the networks see a pose history at their own rate (the asset's train_fps is the natural choice). Every other
// step keeps Z and the blend weights and skins the held deformation T_def with the new pose: on the CPU path it
// reuses T_def and costs about what LBS costs (forward kinematics, skinning, normals); the GPU path re-blends with the
// held weights. The first step, and the first after plInstance_Reset, always runs the networks.
//
// ==================================================================================================================
// BODY CONTACT (docs/asset-format.md, "Body contact")
// ==================================================================================================================
// An asset may carry body points (points of the rest body, each with its normal and the body's own skin weights there)
// and, per garment vertex, a few candidate points near it (asset 1.2: pleat-pack writes the 4 nearest body vertices,
// or up to 16 chosen where simulated cloth was, and each one's ring of body vertices; 1.1 had one point per vertex).
// Each step the points are posed, each takes the posed body's own normal from its ring, and each vertex takes the blend
// of its candidates nearest to it in this pose as its anchor; if it lies closer than body_contact_offset_m to the
// anchor's tangent plane (or behind it, inside the body) it moves out along the anchor's normal to that distance — the
// whole way where its nearest candidate is within 3 cm, not at all beyond 5 cm (a plane that far says little about
// where the body is), a share in between; the normals are computed after. This is the
// simulator's vertex–plane contact measure, applied as a projection: it removes most of the body–garment
// interpenetration a network leaves on motion it never saw, also where the cloth has slid off its rest neighbour on
// the body or the skin folds at a joint (docs/accuracy.md "Body contact"). It costs about what a small network costs
// (docs/benchmarks.md "Body contact"), so there is a cheaper mode, PLEAT_BODY_CONTACT_FAST: each vertex's own point
// only, posed alone, its rest normal turned by its blended matrix (the asset 1.1 contact, and what a scene's LBS-only
// characters get); it needs the asset's first candidate of every vertex to be its own point (pleat-pack writes it so;
// otherwise FAST runs the full contact), and the GPU modes run the full contact for it. On by default where the asset
// has body points (plAssetInfo.has_body_contact); plInstanceDef.body_contact = 0 or plInstance_SetBodyContact turns it
// off. It is continuous in the position (the candidates' weights fall to zero smoothly), so a vertex never jumps when
// it starts or stops touching or changes anchor.
//
// ==================================================================================================================
// GPU NETWORKS (docs/gpu.md, "Networks on the GPU")
// ==================================================================================================================
// With plInstanceDef.mlp_backend = PLEAT_MLP_BACKEND_GPU and a GPU mode, f_LP, the latent guard and f_dec run as GLSL
// compute beside the deformation, so a crowd (plStepInstances) is one upload of X_c per instance and one set of
// dispatches, with no network on the CPU. The CPU still validates, runs the forward kinematics
// and assembles X_c, and reads back Z, w and a finite flag per instance after the dispatches (a few hundred bytes): the
// checks, the numeric reset (recomputed on the CPU's kernels) and the commit are the CPU path's. plStepInstances
// groups such instances of one asset by up to 1,024 (one set of dispatches for a crowd that size). fp32 and fp16
// networks; an int8 asset gives BACKEND_UNAVAILABLE. The GPU sums in another order than the CPU kernels, so the two
// agree within the GL tolerance, not bit for bit.
//
// ==================================================================================================================
// CROWDS: MANY INSTANCES IN ONE CALL (docs/scene-budget.md)
// ==================================================================================================================
// plStepInstances( context, instances, inputs, outputs, results, count ) steps a whole crowd: instance i gets inputs[i]
// and outputs[i], exactly as plInstance_Step( instances[i], &inputs[i], &outputs[i] ) would give it — the same checks,
// results, outputs and state, bit for bit, whatever the crowd's size, order or worker count. Instances of the same
// asset (the SDK's MLP backend) are evaluated together in groups of up to 64: f_LP and f_dec become
// matrix-matrix products and the blend shapes a small GEMM, so each network weight and blend shape is read once per
// group instead of once per instance (a single step is bound by streaming them: 12 MB per fp32 step at the
// reference size). Every instance's dot products keep the single kernels' summation order, which is what makes the
// results identical. The work goes through the task hooks: workers take whole instances for the per-instance stages
// (validation, forward kinematics, X_c, commit), rows or vertex ranges of the batched stages, and lane groups of 8
// instances for skinning, body contact and normals (one vector operation does one scalar operation for 8 of them). On
// CPUs with AVX-512 the batched networks, blend shapes and full body contact use it (PLEAT_KERNEL_SET_AVX512, lane
// groups of 16; the same bits: they repeat the AVX2 single-instance arithmetic per instance). The batch's scratch belongs to the context, sized when instances
// are created (one block per worker, up to 8; context bookkeeping, outside plContext_GetLiveBytes); a call that finds
// it taken by another thread's call uses slower kernels with the same results. Instances in a GPU mode form groups
// per asset and mode: their networks run batched on the CPU, and the deformation of the whole group is one dispatch
// per shader (the instance in gl_WorkGroupID.y) in buffers the group's first instance keeps from its first batch (GPU memory for up to
// 64 instances), then copied to each instance's vertex buffers and read back where asked, as plInstance_Step does
// (the same GLSL per instance: equal to stepping one by one on the GPU within the GL-vs-CPU tolerance, on Mesa
// llvmpipe bit for bit). Instances on the ONNX Runtime backend are stepped one by one inside the call.
//     plInstance crowd[64]; plFrameInput poses[64]; plStepOutput vbos[64]; plResult results[64];
//     ... fill poses[i] and vbos[i] as for plInstance_Step ...
//     plStepInstances( context, crowd, poses, vbos, results, 64 );    // results[i] as plInstance_Step's
//
// ==================================================================================================================
// SCENE BUDGET: TIERS, RATES AND LBS-ONLY UNDER A PER-FRAME BUDGET (docs/scene-budget.md)
// ==================================================================================================================
// A scene (plCreateScene) dresses characters in one garment that comes in several tiers — assets of the same garment
// from the most accurate and costly down (e.g. tshirt, tshirt_medium, tshirt_small, tshirt_xsmall) — and decides every
// frame, from a budget in µs and each character's importance (screen coverage, distance: any weight ≥ 0), which
// detail each character gets: a tier at a network rate, or LBS-only (the garment skinned with no learned deformation).
// The policy spends the budget where it removes the most error per µs, weighted by importance, with hysteresis and a
// minimum time between switches (SCENE BUDGET in docs/scene-budget.md). The engine reads every choice
// (plScene_GetDetail) and can override any (plScene_SetOverride). Costs and errors per tier come from the def
// (measure them: scripts/bench.sh's crowd keys, pleat-eval), or are estimated from each tier's sizes.
// A switch does not pop: the new detail starts from a reset latent and the outputs cross-fade from the old detail to
// the new over plSceneDef.crossfade_frames frames (both are stepped meanwhile). Outputs are on the display mesh,
// tiers[0]'s vertices and faces; a tier on another mesh is carried over by a barycentric map built at creation.
// plScene_Step steps every character through plStepInstances (tiers batched), then finishes the characters (LBS-only
// details, the carry-over to the display mesh, cross-fades, the copies out) over the context's task hooks too, and
// writes each character's outputs: the same bits for any worker count. With plSceneDef.gpu_mode every tier is also a
// GPU detail (GPU NETWORKS), and the policy places each character on the CPU or the GPU within budget_us and
// gpu_budget_us (docs/scene-budget.md, "Two devices"; the GPU costs come from the def, measured on the GPU).
//     plSceneDef sdef = plDefaultSceneDef();
//     sdef.tiers = tiers; sdef.tier_count = 4; sdef.budget_us = 2000.0f; sdef.character_capacity = 100;
//     plScene scene; plCreateScene( context, &sdef, &scene );
//     plCharacterDef cdef = plDefaultCharacterDef(); cdef.beta = ...; uint32_t id; plScene_AddCharacter( scene, &cdef, &id );
//     each frame: plScene_SetImportance( scene, id, coverage ); ...; plScene_Step( scene, poses, vbos, results, count );
//
// ==================================================================================================================
// MEMORY
// ==================================================================================================================
// Every allocation goes through the context's allocator hooks (alloc/free, both or neither; default: the C runtime).
// The context counts the live bytes of its assets and instances (plContext_GetLiveBytes): 0 whenever none is alive,
// so leak tests can check that everything comes back (the host's own counter reaches 0 after plDestroyContext).
// An asset is one 64-byte aligned block: with PLEAT_ASSET_FLAG_USE_IN_PLACE and a 64-byte aligned caller buffer the
// caller's memory is used directly (it must outlive the asset), otherwise the data is copied. An ensemble packed as
// one network (block-diagonal layers, such as the shipped t-shirt's) also gets a packed copy of those layers, each
// block's weights contiguous for the single step (983 KB for the t-shirt), in either case. An instance allocates
// everything when it is created; plInstance_Step allocates nothing.
// Every step streams the asset's network weights and blend shapes in full (12 MB for the fp32 reference garment), so
// the pages they sit in matter: the default allocator gives blocks of 2 MiB and more 2 MiB alignment and, on Linux,
// transparent huge pages (madvise), which measured 11–23 % faster fp32 steps than 4 KiB pages. With your own
// allocator or PLEAT_ASSET_FLAG_USE_IN_PLACE, put the asset in large pages yourself where the platform allows.
//
// ==================================================================================================================
// THREADING
// ==================================================================================================================
// The SDK never creates threads. Give it your task system through the context def (enqueue_task / finish_task, as in
// Box2D v3): the SDK splits the MLP rows, blend shapes, skinning and normals into index ranges. enqueue_task may run
// the task inline and return NULL. Without hooks everything runs serially on the calling thread. Results are
// bit-identical for any worker count (fixed summation order, no atomics).
// Rules: create/destroy/load calls on a context must not overlap with any other call on the same context. After that,
// different instances may be stepped concurrently from different threads; calls on one instance must be serialised.
// Contexts themselves are created and destroyed from one thread at a time (a small process-wide table).
//
// ==================================================================================================================
// ERRORS
// ==================================================================================================================
// Every entry point validates its arguments and returns a plResult: 0 = OK, positive = success with a note
// (PLEAT_RESULT_CLAMPED, PLEAT_RESULT_NUMERIC_RESET), negative = error. An error leaves every object exactly as it was
// before the call (the next output is bit-identical to that of an instance that never saw the failed call; in the GPU
// modes the GPU-side vertex buffers are the one documented exception, see plInstance_Step). Handles are
// written through out parameters and are zero (null) on failure. Nothing aborts, prints or exits; details go to the
// optional log callback with stable item ids (PLEAT_LOG_ITEMS). The codes are one X-macro list too (PLEAT_RESULTS):
// plResultString names a code, plResultDescription says what it means. plGetVersion gives the library's own version,
// to compare with the header's PLEAT_VERSION_* when the shared library may come from another build.
//
// ==================================================================================================================
// HANDLES
// ==================================================================================================================
// plContext, plAsset and plInstance are small values: a slot index and a 32-bit generation (asset and instance handles
// also carry the handle of their context). All zero is null. A handle is valid while its object lives; once the
// object is destroyed it is stale for good and every call through it returns PLEAT_RESULT_INVALID_HANDLE:
// - a slot's generation grows by one each time the slot is reused, so the old handle no longer matches;
// - an asset or instance handle also names its context's generation, so when a new context takes the slot of a
//   destroyed one (and its objects take the same slots in it), the old context's handles name nothing there;
// - a slot whose generation has reached 2^32 − 1 is retired rather than wrapped: it is never handed out again, so a
//   generation, and with it a handle, is never issued twice. A slot retires after 4,294,967,295 objects have lived
//   in it; the 64 context slots therefore last for 2.7 · 10^11 contexts per process, and a retired asset or instance
//   slot keeps its 16 bytes in the context's table until the context is destroyed.
//
// ==================================================================================================================
// ASSET FORMAT
// ==================================================================================================================
// docs/asset-format.md (version 1.0): header with magic "PLEATAST", section table, 64-byte aligned sections, CRC-32.
// Written by the offline tool pleat-pack. Older major versions → PLEAT_RESULT_LEGACY_VERSION, newer →
// PLEAT_RESULT_UNSUPPORTED_VERSION. The networks' weights are fp32, fp16 (pleat-pack --fp16) or, from 1.3, int8
// (pleat-pack --int8: int8 weights with a scale per output channel, each layer's input quantised with a calibrated
// scale, int32 sums, dequantised in float; plAssetInfo.weights_int8). An int8 asset is a quarter of the fp32
// networks' bytes and runs the same on every CPU kernel set (see plKernelSet); a reader older than 1.3 refuses it
// (an unknown header flag) instead of misreading it. From 1.4 the blend shapes may be int8 with a scale per shape
// (pleat-pack --int8-blend-shapes): half of fp16's bytes, which is most of what a large garment's step streams.
#ifndef PLEAT_H
#define PLEAT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined( _WIN32 ) && defined( PLEAT_SHARED )
#if defined( PLEAT_BUILDING )
#define PLEAT_API __declspec( dllexport )
#else
#define PLEAT_API __declspec( dllimport )
#endif
#elif defined( __GNUC__ ) && defined( PLEAT_SHARED ) && defined( PLEAT_BUILDING )
#define PLEAT_API __attribute__( ( visibility( "default" ) ) )
#else
#define PLEAT_API
#endif

/// Marks an entry point kept only for source compatibility; the message names its replacement.
#if defined( __cplusplus ) && __cplusplus >= 201402L
#define PLEAT_DEPRECATED( message ) [[deprecated( message )]]
#elif defined( __GNUC__ )
#define PLEAT_DEPRECATED( message ) __attribute__( ( deprecated( message ) ) )
#elif defined( _MSC_VER )
#define PLEAT_DEPRECATED( message ) __declspec( deprecated( message ) )
#else
#define PLEAT_DEPRECATED( message )
#endif

/// Version of this header (major.minor.patch). The one place the SDK's version is set: the build reads these three
/// lines (CMakeLists.txt) for the CMake package, pleat.pc and the shared library's name and soname.
#define PLEAT_VERSION_MAJOR 0
#define PLEAT_VERSION_MINOR 2
#define PLEAT_VERSION_PATCH 0
/// Asset format major version this runtime reads.
#define PLEAT_ASSET_VERSION_MAJOR 1

/// Hard limits of asset format 1.0.
#define PLEAT_MAX_JOINTS 64
#define PLEAT_MAX_BETAS 16
#define PLEAT_MAX_INFLUENCES 8
#define PLEAT_MAX_LAYERS 10
#define PLEAT_JOINT_NAME_SIZE 32
#define PLEAT_MATERIAL_COUNT 4
/// Body contact (BODY CONTACT below): the modes of plInstanceDef.body_contact, the default clearance and the largest
/// accepted (metres).
#define PLEAT_BODY_CONTACT_OFF 0
#define PLEAT_BODY_CONTACT_ON 1
#define PLEAT_BODY_CONTACT_FAST 2
#define PLEAT_BODY_CONTACT_DEFAULT_OFFSET_M 0.001f
#define PLEAT_BODY_CONTACT_MAX_OFFSET_M 0.05f

// ------------------------------------------------------------------------------------------------------------------
// Results
// ------------------------------------------------------------------------------------------------------------------

/// The one list of result codes: X( name, value, description ). 0 = OK, > 0 = success with a note, < 0 = error
/// (nothing changed). Values never change meaning; new codes get new values.
#define PLEAT_RESULTS( X )                                                                                             \
	X( OK, 0, "success" )                                                                                             \
	X( CLAMPED, 1, "success: an input was clamped to its documented range (beta, material, dt)" )                     \
	X( NUMERIC_RESET, 2,                                                                                              \
	   "success: a non-finite value appeared inside the step; history and latent were reset and the output "         \
	   "recomputed" )                                                                                                 \
	X( INVALID_ARGUMENT, -1, "a pointer is NULL, a count is zero or a value is outside what the function accepts" ) \
	X( INVALID_DEF, -2,                                                                                               \
	   "a def was not made by plDefault...Def() (cookie missing) or has an inconsistent field" )                     \
	X( INVALID_HANDLE, -3, "a handle is null, stale (destroyed) or from another context" )                           \
	X( OUT_OF_MEMORY, -4, "an allocation failed" )                                                                    \
	X( NON_FINITE_INPUT, -5, "a pose, root or dt value is NaN or infinite" )                                          \
	X( INVALID_DT, -6, "dt_s <= 0 or dt_s > 1 s" )                                                                    \
	X( INVALID_QUATERNION, -7, "a quaternion's length is not within 1e-3 of one" )                                    \
	X( JOINT_COUNT_MISMATCH, -8,                                                                                      \
	   "the frame's joint count differs from the instance's engine_joint_count (or a joint map entry is out of "     \
	   "range)" )                                                                                                     \
	X( BUFFER_TOO_SMALL, -9, "an output buffer or span is smaller than required" )                                   \
	X( IO_ERROR, -10, "the asset file could not be opened or read" )                                                  \
	X( TRUNCATED, -11, "the asset data is shorter than its header says" )                                             \
	X( BAD_MAGIC, -12, "the asset data does not start with \"PLEATAST\"" )                                            \
	X( LEGACY_VERSION, -13, "the asset's major version is older than this runtime reads" )                           \
	X( UNSUPPORTED_VERSION, -14, "the asset's major version is newer than this runtime reads" )                      \
	X( CHECKSUM_MISMATCH, -15, "the asset's CRC-32 does not match its contents" )                                     \
	X( MALFORMED_ASSET, -16,                                                                                          \
	   "the asset's structure is broken (header fields, section table, bounds, alignment, sizes, overlap)" )         \
	X( INVALID_ASSET_DATA, -17,                                                                                       \
	   "the asset's structure is sound but its content is not (missing section, wrong dims, index out of range, "    \
	   "non-finite float, non-positive std, skin weights not summing to one, parent order), or an embedded ONNX "    \
	   "model is not well-formed or reaches outside the asset (external tensor data, ONNX Runtime session options; " \
	   "log item ASSET_ONNX_REACHES_OUTSIDE)" )                                                                       \
	X( BACKEND_UNAVAILABLE, -18, "the requested MLP backend (ONNX Runtime) or the asset's ONNX sections are not "   \
								  "available" )                                                                       \
	X( GL_UNAVAILABLE, -19,                                                                                           \
	   "the GPU path was requested but no GL 4.3 context could be used (or the SDK was built without PLEAT_GL)" )    \
	X( GL_ERROR, -20, "a GL call failed" )                                                                            \
	X( ASSET_IN_USE, -21, "plDestroyAsset was called while instances still use the asset" )                          \
	X( NOT_FOUND, -22, "a lookup (joint name) found nothing" )                                                        \
	X( CAPACITY_EXCEEDED, -23, "the context's object table is full (too many contexts, assets or instances)" )       \
	X( INTERNAL_ERROR, -24,                                                                                           \
	   "a runtime job rejected the buffers the SDK built for it: a defect of the SDK, not of the call (please "      \
	   "report it); plInstance_Step stops before its commit (history, latent, weights and skinning matrices "        \
	   "unchanged), but on the CPU path the positions and normals may be partly written" )

/// Result of every entry point (PLEAT_RESULT_ + name in PLEAT_RESULTS).
typedef enum plResult
{
#define PLEAT_RESULT_ENUM_( name, value, description ) PLEAT_RESULT_##name = value,
	PLEAT_RESULTS( PLEAT_RESULT_ENUM_ )
#undef PLEAT_RESULT_ENUM_
} plResult;

/// Stable name of a result code, e.g. "PLEAT_RESULT_CLAMPED"; "PLEAT_RESULT_UNKNOWN" for values not listed.
PLEAT_API const char* plResultString( plResult result );
/// What a result code means (its description in PLEAT_RESULTS); "unknown result" for values not listed.
PLEAT_API const char* plResultDescription( plResult result );

/// Version of the library itself, which may differ from the header's PLEAT_VERSION_* when an application runs with
/// another build of the shared library than it was compiled against (compare the major versions).
typedef struct plVersion
{
	uint32_t major;       ///< PLEAT_VERSION_MAJOR of the library's build
	uint32_t minor;       ///< PLEAT_VERSION_MINOR
	uint32_t patch;       ///< PLEAT_VERSION_PATCH
	uint32_t asset_major; ///< PLEAT_ASSET_VERSION_MAJOR: the asset format major version it reads
} plVersion;

/// The library's version (cannot fail; callable before any context exists).
PLEAT_API plVersion plGetVersion( void );

// ------------------------------------------------------------------------------------------------------------------
// Log
// ------------------------------------------------------------------------------------------------------------------

/// The one list of log items: X( name, stable id, message ). Ids never change meaning; new items get new ids.
#define PLEAT_LOG_ITEMS( X )                                                                                         \
	X( NONE, 0, "no item" )                                                                                           \
	X( CONTEXT_CREATED, 1, "context created" )                                                                        \
	X( CONTEXT_DESTROYED_WITH_LIVE_OBJECTS, 2, "context destroyed while assets or instances were alive" )             \
	X( KERNELS_SCALAR, 3, "CPU kernels: scalar" )                                                                     \
	X( KERNELS_AVX2, 4, "CPU kernels: AVX2 + FMA + F16C" )                                                            \
	X( KERNELS_AVX512, 5, "CPU kernels: AVX2 + FMA + F16C, batched networks and blend shapes AVX-512" )               \
	X( ASSET_LOADED, 10, "asset loaded" )                                                                             \
	X( ASSET_COPIED, 11, "asset data copied to an aligned block (not used in place)" )                               \
	X( ASSET_IO_ERROR, 12, "asset file could not be read" )                                                           \
	X( ASSET_BAD_HEADER, 13, "asset header rejected" )                                                                \
	X( ASSET_CHECKSUM_MISMATCH, 14, "asset CRC-32 mismatch" )                                                         \
	X( ASSET_BAD_SECTION_TABLE, 15, "asset section table rejected" )                                                  \
	X( ASSET_BAD_CONTENT, 16, "asset content rejected" )                                                              \
	X( ASSET_IN_USE, 17, "asset destroyed while instances use it" )                                                   \
	X( ASSET_ONNX_REACHES_OUTSIDE, 18, "asset ONNX model reaches outside the asset (external data, session config)" ) \
	X( INSTANCE_CREATED, 20, "instance created" )                                                                     \
	X( INSTANCE_NUMERIC_RESET, 21, "non-finite value inside a step: history and latent reset" )                       \
	X( INSTANCE_INPUT_CLAMPED, 22, "an input was clamped to its range" )                                              \
	X( INSTANCE_BAD_INPUT, 23, "a step input was rejected" )                                                          \
	X( INSTANCE_BAD_DEF, 24, "instance def rejected" )                                                                \
	X( INSTANCE_STALE_HANDLE, 25, "an instance handle names no live instance (destroyed, or of another context)" )    \
	X( BACKEND_UNAVAILABLE, 30, "ONNX Runtime backend unavailable" )                                                  \
	X( GL_UNAVAILABLE, 31, "GL deformer unavailable" )                                                                \
	X( GL_HEADLESS_CONTEXT, 32, "headless GL context created" )                                                       \
	X( OUT_OF_MEMORY, 40, "allocation failed" )                                                                       \
	X( SCENE_BAD_DEF, 50, "scene or character def rejected" )                                                         \
	X( SCENE_CREATED, 51, "scene created" )

/// Log item ids (PLEAT_LOG_ + name in PLEAT_LOG_ITEMS).
typedef enum plLogItem
{
#define PLEAT_LOG_ITEM_ENUM_( name, id, message ) PLEAT_LOG_##name = id,
	PLEAT_LOG_ITEMS( PLEAT_LOG_ITEM_ENUM_ )
#undef PLEAT_LOG_ITEM_ENUM_
} plLogItem;

/// Severity of a log message.
typedef enum plLogLevel
{
	PLEAT_LOG_LEVEL_ERROR = 1,
	PLEAT_LOG_LEVEL_WARNING = 2,
	PLEAT_LOG_LEVEL_INFO = 3,
} plLogLevel;

/// The fixed message of a log item ("unknown item" for ids not listed).
PLEAT_API const char* plLogItemString( plLogItem item );

/// Log callback: item is stable, message is the item's text plus detail (valid only during the call).
typedef void plLogFn( plLogLevel level, plLogItem item, const char* message, void* user_context );

// ------------------------------------------------------------------------------------------------------------------
// Host hooks
// ------------------------------------------------------------------------------------------------------------------

/// Allocate size bytes aligned to align (a power of two, >= 16); return NULL on failure.
typedef void* plAllocFn( size_t size, size_t align, void* user_context );
/// Free a block from plAllocFn; size is the size that was requested.
typedef void plFreeFn( void* ptr, size_t size, void* user_context );

/// A task body: process items [start_index, end_index) as worker worker_index (< worker_count).
typedef void plTaskFn( uint32_t start_index, uint32_t end_index, uint32_t worker_index, void* task_context );
/// Split item_count items into ranges of at least min_range items and run task on them (possibly in parallel).
/// Return a handle passed to plFinishTaskFn, or NULL if the task already ran to completion inline.
typedef void* plEnqueueTaskFn( plTaskFn* task, uint32_t item_count, uint32_t min_range, void* task_context,
							   void* user_context );
/// Wait until the enqueued task has finished.
typedef void plFinishTaskFn( void* user_task, void* user_context );

// ------------------------------------------------------------------------------------------------------------------
// Handles: small value ids (index + generation, HANDLES above); all zero = null. Copy them freely.
// ------------------------------------------------------------------------------------------------------------------

/// A context handle.
typedef struct plContext
{
	uint32_t index1;     ///< slot index + 1 in the process-wide context table (0 = null)
	uint32_t generation; ///< the slot's generation when the context was created (>= 1)
} plContext;

/// An asset handle.
typedef struct plAsset
{
	uint32_t index1;     ///< slot index + 1 in the context's asset table (0 = null)
	uint32_t generation; ///< the slot's generation when the asset was loaded (>= 1)
	plContext context;   ///< the context the asset was loaded into
} plAsset;

/// An instance handle.
typedef struct plInstance
{
	uint32_t index1;     ///< slot index + 1 in the context's instance table (0 = null)
	uint32_t generation; ///< the slot's generation when the instance was created (>= 1)
	plContext context;   ///< the context the instance was created in
} plInstance;

// ------------------------------------------------------------------------------------------------------------------
// Context
// ------------------------------------------------------------------------------------------------------------------

/// The CPU kernel sets, narrowest first (a context chooses one at creation: plContextDef.max_isa). What is
/// bit-identical to what (the tests named check each statement):
/// - Within one kernel set and one weight precision (the asset's fp32 or fp16), results are bit-identical for any
///   worker count (test_determinism_across_workers), and plStepInstances gives each instance exactly what
///   plInstance_Step gives it (test_batch_step_matches_single): the batched kernels are twins of the single ones.
/// - PLEAT_KERNEL_SET_AVX512 gives exactly what PLEAT_KERNEL_SET_AVX2 gives: its AVX-512 kernels repeat the AVX2
///   arithmetic per instance (test_batched_kernels_match_single).
/// - Between the scalar set and the SIMD sets results agree to rounding, not bit for bit: the SIMD sums group terms
///   differently and fuse multiply-adds. Vertex normals from equal positions are bit-identical; the networks, blend
///   shapes, skinning and body contact agree within test_simd_matches_scalar's bounds (a whole step: positions within
///   1e-5 m).
/// - int8 networks (asset 1.3) are bit-identical across every set, the scalar one included, and to the numpy
///   reference (pleat.reference.mlp.mlp_int8, ReLU networks): their sums are integer, the int8 kernels (scalar, AVX2,
///   AVX-VNNI and AVX-512 VNNI where the CPU has them) differ only in how they form them
///   (test_int8_matches_reference). The rest of the step follows the rules above.
typedef enum plKernelSet
{
	PLEAT_KERNEL_SET_SCALAR = 0, ///< the scalar kernels (the specification; every build has them)
	PLEAT_KERNEL_SET_AVX2 = 1,   ///< AVX2 + FMA + F16C variants
	PLEAT_KERNEL_SET_AVX512 = 2, ///< the AVX2 set, with plStepInstances's batched networks and blend shapes in AVX-512
	                             ///< F/VL/BW/DQ (16 instances per vector); the single-instance kernels are AVX2's
} plKernelSet;

/// Context definition: get one from plDefaultContextDef(), change fields, pass to plCreateContext.
typedef struct plContextDef
{
	plAllocFn* alloc;              ///< allocator (NULL together with free = C runtime aligned_alloc/free)
	plFreeFn* free;                ///< deallocator (both or neither)
	void* allocator_context;       ///< passed to alloc/free
	plEnqueueTaskFn* enqueue_task; ///< task system (NULL together with finish_task = serial)
	plFinishTaskFn* finish_task;   ///< task completion (both or neither)
	void* task_context;            ///< passed to enqueue_task/finish_task
	uint32_t worker_count;         ///< number of workers the task system may use (1..64; default 1)
	plLogFn* log;                  ///< optional log callback (NULL = silent)
	void* log_context;             ///< passed to log
	int force_scalar;              ///< deprecated: max_isa = PLEAT_KERNEL_SET_SCALAR. Non-zero acts as that (flag)
	plKernelSet max_isa;           ///< the widest CPU kernel set the context may choose (default: the widest,
	                               ///< PLEAT_KERNEL_SET_AVX512); it takes the widest set up to this one that the build
	                               ///< has and the CPU runs, once, at creation (plContext_GetKernelSet says which);
	                               ///< a value above PLEAT_KERNEL_SET_AVX512 means the widest, a negative one is
	                               ///< INVALID_DEF
	int32_t internal_cookie;       ///< set by plDefaultContextDef; do not touch
} plContextDef;

/// A context def with defaults and the validity cookie.
PLEAT_API plContextDef plDefaultContextDef( void );
/// Create a context. out_context is written (null on failure).
PLEAT_API plResult plCreateContext( const plContextDef* def, plContext* out_context );
/// Destroy a context and every asset and instance still alive in it.
PLEAT_API plResult plDestroyContext( plContext context );
/// Non-zero if the handle names a live context.
PLEAT_API int plContext_IsValid( plContext context );
/// Bytes currently allocated through the context's allocator for assets and instances (copied asset blocks, instance
/// buffers, GPU and ONNX Runtime backend objects). The context's own bookkeeping — its block and its handle tables,
/// which grow with the most objects ever alive at once and are freed with the context — goes through the same
/// allocator hooks but is not counted: the value is exactly 0 right after plCreateContext and again whenever no asset
/// or instance is alive, so a leak test compares it with 0.
PLEAT_API plResult plContext_GetLiveBytes( plContext context, uint64_t* out_bytes );
/// The kernel set the context chose at creation, in *out_kernel_set (PLEAT_KERNEL_SET_SCALAR on failure); the log item
/// KERNELS_SCALAR, KERNELS_AVX2 or KERNELS_AVX512 at creation says the same. Every step, crowd and scene of the context
/// runs that set.
PLEAT_API plResult plContext_GetKernelSet( plContext context, plKernelSet* out_kernel_set );
/// Deprecated: plContext_GetKernelSet. Non-zero in *out_avx2 if the single-instance kernels are AVX2's
/// (PLEAT_KERNEL_SET_AVX2 or PLEAT_KERNEL_SET_AVX512).
PLEAT_DEPRECATED( "use plContext_GetKernelSet" )
PLEAT_API plResult plContext_UsesAvx2( plContext context, int* out_avx2 );

// ------------------------------------------------------------------------------------------------------------------
// Asset
// ------------------------------------------------------------------------------------------------------------------

/// Asset def flag: the caller's buffer may be used in place (if it is 64-byte aligned); it must outlive the asset.
#define PLEAT_ASSET_FLAG_USE_IN_PLACE 0x1u
/// Asset def flag: skip the CRC-32 check (structure and content are still validated).
#define PLEAT_ASSET_FLAG_SKIP_CHECKSUM 0x2u

/// Asset definition: either data + size (a block in memory) or path (a file), not both.
typedef struct plAssetDef
{
	const void* data;        ///< asset bytes in memory (or NULL)
	size_t size;             ///< size of data in bytes
	const char* path;        ///< file path (or NULL), read into an aligned block
	uint32_t flags;          ///< PLEAT_ASSET_FLAG_* bits
	int32_t internal_cookie; ///< set by plDefaultAssetDef; do not touch
} plAssetDef;

/// Counts and names of a loaded asset (pointers valid while the asset lives).
typedef struct plAssetInfo
{
	uint32_t vertex_count;      ///< N (count)
	uint32_t face_count;        ///< F (count)
	uint32_t joint_count;       ///< J (count)
	uint32_t input_joint_count; ///< Jin (count)
	uint32_t influence_count;   ///< K (count)
	uint32_t beta_count;        ///< B (count)
	uint32_t latent_count;      ///< L (count)
	uint32_t blend_count;       ///< D (count)
	uint32_t input_count;       ///< I = size of X_c (count)
	uint32_t lp_layer_count;    ///< latent predictor layers (count)
	uint32_t dec_layer_count;   ///< decoder layers (count)
	int weights_fp16;           ///< non-zero if some weights are stored as fp16
	float dt_min_s;             ///< dt is clamped up to this (seconds)
	float dt_max_s;             ///< dt is clamped down to this (seconds)
	float beta_min;             ///< β lower clamp (unitless shape coefficient)
	float beta_max;             ///< β upper clamp (unitless)
	float material_min[4];      ///< (areal density m kg/m², μ N/m, λ N/m, bending k J) lower clamp
	float material_max[4];      ///< upper clamp, same units
	float material_default[4];  ///< default material, same units
	float train_fps;            ///< frame rate of the training data (frames per second, information)
	char name[65];              ///< garment name, utf-8, NUL-terminated
	const char* meta_json;      ///< META section (utf-8 JSON, NOT NUL-terminated) or NULL
	size_t meta_json_size;      ///< META size in bytes (0 if absent)
	int has_onnx_lp;            ///< non-zero if the OXLP section (ONNX latent predictor) exists
	int has_onnx_decoder;       ///< non-zero if the OXDC section (ONNX decoder) exists
	uint32_t pinned_count;      ///< number of pinned vertices (PINS, information), 0 if absent
	int has_body_contact;       ///< non-zero if the asset carries body anchors (BANC … sections, BODY CONTACT above)
	int weights_int8;           ///< non-zero if the networks are int8 (asset 1.3: int8 weights, per-output-channel
	                            ///< scales, calibrated input scales; the CPU runs them in int32, the ONNX sections
	                            ///< stay the float networks)
} plAssetInfo;

/// An asset def with defaults and the validity cookie.
PLEAT_API plAssetDef plDefaultAssetDef( void );
/// Load and validate an asset (structure, then content, then CRC-32 unless skipped). A path must name a regular file:
/// a directory, FIFO, socket or device is IO_ERROR at once (checked before it is opened, so a FIFO without a writer
/// cannot block the call), with the reason in the ASSET_IO_ERROR log line.
PLEAT_API plResult plLoadAsset( plContext context, const plAssetDef* def, plAsset* out_asset );
/// Destroy an asset; PLEAT_RESULT_ASSET_IN_USE (and nothing happens) while instances use it.
PLEAT_API plResult plDestroyAsset( plAsset asset );
/// Non-zero if the handle names a live asset.
PLEAT_API int plAsset_IsValid( plAsset asset );
/// Counts, ranges, name and META of the asset.
PLEAT_API plResult plAsset_GetInfo( plAsset asset, plAssetInfo* out_info );
/// Name of asset joint joint_index (NUL-terminated, valid while the asset lives).
PLEAT_API plResult plAsset_GetJointName( plAsset asset, uint32_t joint_index, const char** out_name );
/// The garment's triangles, [face_count][3] vertex indices (each < vertex_count), counter-clockwise seen from outside:
/// what an engine needs for its index buffer (the vertices are the N positions/normals plInstance_Step writes).
/// Points into the asset's block (read in place; valid while the asset lives). out_faces and out_face_count are
/// required; both are zeroed on failure.
PLEAT_API plResult plAsset_GetFaces( plAsset asset, const uint32_t** out_faces, uint32_t* out_face_count );
/// The garment template T, [vertex_count][3] in rest space (metres): the mean body's undeformed garment, without the
/// shape term G_S(β) or any pose (for bounds, UV baking or a static fallback mesh; an instance's own rest shape
/// T + G_S(β) is what plInstance_GetPositions returns before its first step). Points into the asset's block (valid
/// while the asset lives). Both out parameters are required and zeroed on failure.
PLEAT_API plResult plAsset_GetTemplatePositions( plAsset asset, const float** out_positions, uint32_t* out_vertex_count );
/// Index of the asset joint called name (exact match), PLEAT_RESULT_NOT_FOUND if none.
PLEAT_API plResult plAsset_FindJoint( plAsset asset, const char* name, int32_t* out_joint_index );

// ------------------------------------------------------------------------------------------------------------------
// Instance
// ------------------------------------------------------------------------------------------------------------------

/// Which code evaluates the two MLPs.
typedef enum plMlpBackend
{
	PLEAT_MLP_BACKEND_PLEAT = 0,       ///< the SDK's own CPU kernels (default)
	PLEAT_MLP_BACKEND_ONNXRUNTIME = 1, ///< ONNX Runtime (loaded at run time), needs the asset's OXLP/OXDC sections
	PLEAT_MLP_BACKEND_GPU = 2,         ///< GLSL compute beside the deformation: needs a GPU mode (else INVALID_DEF) and
	                                   ///< fp32 or fp16 networks (int8: BACKEND_UNAVAILABLE); see GPU NETWORKS
} plMlpBackend;

/// Where blend shapes, skinning and normals run.
typedef enum plGpuMode
{
	PLEAT_GPU_MODE_NONE = 0,         ///< CPU (default)
	PLEAT_GPU_MODE_HOST_CONTEXT = 1, ///< GL 4.3 compute in the engine's context, current on the calling thread for
	                                 ///< every call on the instance (with none current: GL_UNAVAILABLE, nothing changed)
	PLEAT_GPU_MODE_HEADLESS = 2,     ///< GL 4.3 compute in a headless context the SDK creates (EGL, OSMesa fallback)
} plGpuMode;
/// Deprecated spellings of the plGpuMode constants (before they took the PLEAT_<TYPE>_ prefix of every other enum).
#define PLEAT_GPU_NONE PLEAT_GPU_MODE_NONE
#define PLEAT_GPU_HOST_CONTEXT PLEAT_GPU_MODE_HOST_CONTEXT
#define PLEAT_GPU_HEADLESS PLEAT_GPU_MODE_HEADLESS

/// Instance definition: get one from plDefaultInstanceDef(), change fields, pass to plCreateInstance.
typedef struct plInstanceDef
{
	plAsset asset;                     ///< the garment asset (required)
	const int32_t* joint_map;          ///< [joint_map_count]: engine joint index per asset joint, -1 = identity;
	                                   ///< each engine joint at most once (else INVALID_DEF, both entries logged);
	                                   ///< NULL = the engine uses the asset's joint order
	uint32_t joint_map_count;          ///< must equal the asset's joint count when joint_map is set (count)
	uint32_t engine_joint_count;       ///< joints per plFrameInput (count); 0 = the asset's joint count
	const float* beta;                 ///< [beta_count] initial body shape β (unitless), NULL = zeros
	uint32_t beta_count;               ///< entries in beta, <= the asset's B; missing entries are 0 (count)
	const float* material;             ///< [4] initial (areal density m kg/m², μ N/m, λ N/m, bending k J), NULL = asset default
	plMlpBackend mlp_backend;          ///< PLEAT_MLP_BACKEND_PLEAT (default) or _ONNXRUNTIME
	const char* onnxruntime_library;   ///< path of libonnxruntime (NULL = search, see ort_backend)
	plGpuMode gpu_mode;                ///< PLEAT_GPU_MODE_NONE (default), _HOST_CONTEXT or _HEADLESS
	uint32_t host_position_buffer;     ///< host-context mode: GL buffer name for positions (vec4 per vertex), 0 = own
	uint32_t host_normal_buffer;       ///< host-context mode: GL buffer name for normals (vec4 per vertex), 0 = own
	float network_rate_hz;             ///< run the networks at most this often (Hz, e.g. the asset's train_fps under a
	                                   ///< 60–120 fps game loop); steps in between skin the last learned deformation
	                                   ///< with the new pose (UPDATE RATE above). 0 = every step (default)
	int body_contact;                  ///< PLEAT_BODY_CONTACT_ON (1, default): keep vertices outside the body where the
	                                   ///< asset carries body points (BODY CONTACT above); PLEAT_BODY_CONTACT_FAST (2):
	                                   ///< the cheaper contact; 0 = plain skinning; other values: INVALID_DEF
	float body_contact_offset_m;       ///< clearance kept from the body (metres, 0 .. PLEAT_BODY_CONTACT_MAX_OFFSET_M;
	                                   ///< default PLEAT_BODY_CONTACT_DEFAULT_OFFSET_M = 1 mm); outside or not
	                                   ///< finite: PLEAT_RESULT_INVALID_DEF
	plInstance gpu_share;              ///< GPU modes: a live instance of the same asset, GPU mode and MLP backend whose
	                                   ///< GPU data this one shares (programs, blend shapes, skinning, network weights;
	                                   ///< headless: its context) instead of a copy of its own, so that a crowd costs
	                                   ///< one copy of the asset on the GPU; the two are then stepped from one thread
	                                   ///< at a time (host-context mode: in one context or share group). Zero handle
	                                   ///< (default) = none; otherwise anything else is INVALID_DEF
	void* user_data;                   ///< yours, returned by plInstance_GetUserData
	int32_t internal_cookie;           ///< set by plDefaultInstanceDef; do not touch
} plInstanceDef;

/// A quaternion (x, y, z, w), unit length.
typedef struct plQuat
{
	float x, y, z, w;
} plQuat;

/// A 3-vector (metres where it is a position).
typedef struct plVec3
{
	float x, y, z;
} plVec3;

/// One frame of pose, as an engine has it. This pose is frame t+1 (see FRAME CONVENTION).
typedef struct plFrameInput
{
	const float* joint_rotations; ///< local joint rotations (x, y, z, w) relative to the asset's rest pose (SKELETON
	                              ///< AND REST POSE above), in engine joint order (unit quaternions)
	uint32_t joint_count;         ///< engine joints in joint_rotations (count), must equal engine_joint_count
	uint32_t joint_stride_bytes;  ///< bytes from one joint's quaternion to the next (0 = 16)
	plVec3 root_translation;      ///< root translation t_root (metres)
	plQuat root_rotation;         ///< root rotation Q_root (unit quaternion); all zero is taken as identity
	float dt_s;                   ///< time since the previous pose (seconds), (0, 1], clamped to the asset's range
} plFrameInput;

/// Optional destinations for plInstance_Step: strided spans (interleaved or planar) of 3 floats per vertex.
typedef struct plStepOutput
{
	float* positions;               ///< [vertex_capacity] x, y, z (metres) or NULL
	uint32_t position_stride_bytes; ///< bytes between vertices (0 = 12), multiple of 4
	float* normals;                 ///< [vertex_capacity] unit normals or NULL
	uint32_t normal_stride_bytes;   ///< bytes between vertices (0 = 12), multiple of 4
	uint32_t vertex_capacity;       ///< vertices the spans hold (count), must be >= N
} plStepOutput;

/// An instance def with defaults and the validity cookie.
PLEAT_API plInstanceDef plDefaultInstanceDef( void );
/// Create an instance of an asset (allocates everything it will need).
PLEAT_API plResult plCreateInstance( plContext context, const plInstanceDef* def, plInstance* out_instance );
/// Destroy an instance.
PLEAT_API plResult plDestroyInstance( plInstance instance );
/// Non-zero if the handle names a live instance (asking logs nothing; every other call through a stale handle
/// returns INVALID_HANDLE and logs INSTANCE_STALE_HANDLE with the function's name).
PLEAT_API int plInstance_IsValid( plInstance instance );
/// Advance one frame: the pose is frame t+1. Writes positions/normals to output (may be NULL) and to the instance's
/// own buffers. Returns OK, CLAMPED (dt clamped) or NUMERIC_RESET; an error changes nothing.
/// Checks, in this order: handle, pointers and spans (INVALID_ARGUMENT, BUFFER_TOO_SMALL), joint count
/// (JOINT_COUNT_MISMATCH), NaN/Inf anywhere in the used pose, root or dt (NON_FINITE_INPUT), quaternion lengths
/// (INVALID_QUATERNION), dt range (INVALID_DT). Engine joints the joint map does not reference are not read.
/// NUMERIC_RESET: a non-finite value appeared in f_LP's output, the blend weights or the outputs; the history and
/// latent were reset and the step recomputed as a first frame. If even that is non-finite, the step dresses the body
/// without learned deformation (zero latent and blend weights) and still returns NUMERIC_RESET.
/// GPU modes: positions/normals are read back from the GPU only when output asks for them; otherwise they stay on
/// the GPU (in the host buffers, if given) and plInstance_GetPositions/GetNormals keep the last read-back.
/// A GL error (PLEAT_RESULT_GL_ERROR, GL_UNAVAILABLE) leaves the latent, the pose history, the skinning matrices,
/// the blend weights, plInstance_GetPositions/GetNormals and the output spans unchanged: read-backs land in scratch
/// and are copied only once the step has succeeded. The GPU buffers themselves (the engine's host buffers or the
/// SDK's own) are the one exception: the compute passes write them in place, so after a failed step they may hold a
/// partial result of that step (keeping a second GPU copy to roll back to would cost 2 × N × 32 bytes of GPU memory
/// and a copy per step); the next successful step rewrites every vertex.
PLEAT_API plResult plInstance_Step( plInstance instance, const plFrameInput* input, const plStepOutput* output );
/// Step count instances of one context in one call (CROWDS above): instance i exactly as
/// plInstance_Step( instances[i], &inputs[i], outputs != NULL ? &outputs[i] : NULL ) would step it, bit for bit, with
/// the networks and blend shapes of instances that share an asset evaluated together. instances, inputs: [count];
/// outputs: [count] or NULL; out_results: [count] or NULL, instance i's own result (INVALID_HANDLE for a null or stale
/// handle or one of another context). An instance whose step fails is left exactly as it was and the others still
/// step; an instance listed twice is stepped twice, in list order. Returns INVALID_HANDLE (context) or
/// INVALID_ARGUMENT (instances or inputs NULL while count > 0) having changed nothing; else the first error in list
/// order, else the first note (CLAMPED, NUMERIC_RESET), else OK (also for count 0). Allocates nothing; thread rules as
/// for plInstance_Step, for every instance listed.
PLEAT_API plResult plStepInstances( plContext context, const plInstance* instances, const plFrameInput* inputs,
									const plStepOutput* outputs, plResult* out_results, uint32_t count );
/// Forget the pose history and latent: the next step is a first frame.
PLEAT_API plResult plInstance_Reset( plInstance instance );
/// Change how often the networks run (Hz; 0 = every step): plInstanceDef.network_rate_hz, e.g. lower for a character
/// far from the camera. The time already gathered since the last network update is kept. INVALID_ARGUMENT if not
/// finite or negative (nothing changes).
PLEAT_API plResult plInstance_SetNetworkRate( plInstance instance, float network_rate_hz );
/// Set body contact (0, PLEAT_BODY_CONTACT_ON or PLEAT_BODY_CONTACT_FAST) and its clearance (BODY CONTACT above;
/// plInstanceDef.body_contact and body_contact_offset_m). Applies from the next step. INVALID_ARGUMENT if the mode is
/// not one of those or offset_m is not finite or outside 0 .. 0.05 m (nothing changes); turning it on for an asset
/// without body points is OK and changes nothing. GPU modes: a GL error (GL_ERROR, GL_UNAVAILABLE) leaves the setting
/// as it was.
PLEAT_API plResult plInstance_SetBodyContact( plInstance instance, int enabled, float offset_m );
/// Set the body shape β ([beta_count] unitless, missing entries 0); recomputes the shaped template and J(β) once.
/// Values outside [beta_min, beta_max] are clamped (PLEAT_RESULT_CLAMPED). GPU modes upload the new template first:
/// a GL error (GL_ERROR, GL_UNAVAILABLE) leaves β, J(β) and the template, on the CPU and on the GPU, as they were.
PLEAT_API plResult plInstance_SetShape( plInstance instance, const float* beta, uint32_t beta_count );
/// Set the material (areal density m kg/m², μ N/m, λ N/m, bending k J); values outside the asset's ranges are clamped (CLAMPED).
PLEAT_API plResult plInstance_SetMaterial( plInstance instance, const float material[4] );
/// The last step's positions [N][3] (metres), owned by the instance, valid until the next step or destroy. Before the
/// first step: the shaped rest template T + G_S(β) (no pose, no learned deformation).
PLEAT_API plResult plInstance_GetPositions( plInstance instance, const float** out_positions, uint32_t* out_count );
/// The last step's normals [N][3] (unit), owned by the instance, valid until the next step or destroy.
PLEAT_API plResult plInstance_GetNormals( plInstance instance, const float** out_normals, uint32_t* out_count );
/// Copy the last step's skinning matrices, [J][3][4] row-major (rest space → output space, metres).
/// joint_count must be the asset's J (PLEAT_RESULT_BUFFER_TOO_SMALL if smaller).
PLEAT_API plResult plInstance_GetSkinMatrices( plInstance instance, float* out, uint32_t joint_count );
/// Copy the current latent Z_t [L] (after the latent guard); latent_count must be >= L.
PLEAT_API plResult plInstance_GetLatent( plInstance instance, float* out, uint32_t latent_count );
/// Copy the last step's blend weights w [D]; blend_count must be >= D.
PLEAT_API plResult plInstance_GetBlendWeights( plInstance instance, float* out, uint32_t blend_count );
/// Copy the current (clamped) β [B] and material [4].
PLEAT_API plResult plInstance_GetShape( plInstance instance, float* out_beta, uint32_t beta_count, float out_material[4] );
/// The asset the instance was created from.
PLEAT_API plResult plInstance_GetAsset( plInstance instance, plAsset* out_asset );
/// The def's user_data, in *out_user_data (NULL on failure).
PLEAT_API plResult plInstance_GetUserData( plInstance instance, void** out_user_data );

// ------------------------------------------------------------------------------------------------------------------
// Skeleton and rest pose (SKELETON AND REST POSE above)
// ------------------------------------------------------------------------------------------------------------------

/// One joint of the asset's rest pose, laid out as an engine's reference (bind) pose: what a retarget from another
/// bind pose reads. Rest space: metres, +Y up, facing +Z, the body's left at +X.
typedef struct plRestJoint
{
	int32_t parent;           ///< parent joint index (always < this joint's index), -1 for joint 0, the root
	plVec3 position;          ///< rest joint position J_k(β) (metres, rest space; the mean body's pelvis is at 0)
	plVec3 local_translation; ///< J_k(β) − J_parent(β) (metres, rest space); J_0(β) for the root
	plQuat local_rotation;    ///< rest local rotation (x, y, z, w): identity for every joint, since the rotations
	                          ///< plInstance_Step takes are measured from this pose (given so that a generic
	                          ///< retarget reads it like any other reference pose)
} plRestJoint;

/// The asset's rest pose for the mean body (β = 0): out_joints[k] for asset joint k, k < the asset's joint count.
/// joint_capacity: entries out_joints holds (BUFFER_TOO_SMALL if fewer than the asset's joint count; nothing written).
PLEAT_API plResult plAsset_GetRestPose( plAsset asset, plRestJoint* out_joints, uint32_t joint_capacity );
/// The rest pose for the instance's current (clamped) β: positions J(β) = J_template + Σ_b β_b · J_shapedirs[b], the
/// joints the instance's forward kinematics uses. Changes with plInstance_SetShape (rebuild a retarget then: bone
/// directions move a little with β). Same layout and capacity rule as plAsset_GetRestPose.
PLEAT_API plResult plInstance_GetRestPose( plInstance instance, plRestJoint* out_joints, uint32_t joint_capacity );

// ------------------------------------------------------------------------------------------------------------------
// Scene budget (SCENE BUDGET above)
// ------------------------------------------------------------------------------------------------------------------

/// Hard limits of a scene.
#define PLEAT_MAX_TIERS 8
#define PLEAT_MAX_NETWORK_RATES 4

/// A scene handle (as plInstance: slot index + 1, generation, context; all zero = null).
typedef struct plScene
{
	uint32_t index1;     ///< slot index + 1 in the context's scene table (0 = null)
	uint32_t generation; ///< the slot's generation when the scene was created (>= 1)
	plContext context;   ///< the context the scene was created in
} plScene;

/// One level of detail of a character.
typedef struct plDetail
{
	int32_t tier;          ///< index into plSceneDef.tiers, or -1: LBS-only (skinning only, on the display mesh)
	float network_rate_hz; ///< the tier's network rate (Hz; 0 = every step, else one of plSceneDef.network_rates_hz)
	int32_t gpu;           ///< 1: the tier runs on the GPU (a scene with plSceneDef.gpu_mode), 0: on the CPU
} plDetail;

/// Scene definition: get one from plDefaultSceneDef(), change fields, pass to plCreateScene.
typedef struct plSceneDef
{
	const plAsset* tiers;              ///< [tier_count] one garment, most accurate (and costly) first (required). Same
	                                   ///< skeleton in every tier; tiers[0]'s mesh is the display mesh
	uint32_t tier_count;               ///< 1..PLEAT_MAX_TIERS
	const float* tier_cost_us;         ///< [tier_count] µs per character for a step with the networks, stepped in a
	                                   ///< crowd (plStepInstances); NULL = estimated from each tier's sizes
	const float* tier_skin_cost_us;    ///< [tier_count] µs per character for a step between network updates (skinning
	                                   ///< and normals); NULL = estimated
	const float* tier_stream_cost_us;  ///< [tier_count] µs per frame for reading a tier's weights and blend shapes
	                                   ///< once, paid by a tier that any character uses; NULL = estimated
	const float* tier_error_mm;        ///< [tier_count] mean error of each tier (mm, e.g. pleat-eval against the
	                                   ///< simulator); NULL = ranks: tier t counts (t + 1) / (tier_count + 1) of LBS
	float lbs_cost_us;                 ///< µs per character for LBS-only; 0 = estimated
	float lbs_error_mm;                ///< mean error of LBS-only (mm); 0 = 1 (then the errors are relative)
	const float* network_rates_hz;     ///< [network_rate_count] reduced network rates the policy may pick (Hz, each
	                                   ///< below frame_rate_hz), e.g. { 30, 15 }; every tier also has its full rate
	const float* network_rate_error_mm; ///< [network_rate_count] error added at that rate (mm); NULL = a small penalty
	                                   ///< (2 % of the tier's error per halving) so spare budget goes to full rates
	uint32_t network_rate_count;       ///< 0..PLEAT_MAX_NETWORK_RATES
	float frame_rate_hz;               ///< the game's frame rate (Hz; 0 = 60): what a reduced rate saves
	float budget_us;                   ///< per-frame budget for the whole scene (µs); 0 = unlimited
	float hysteresis;                  ///< a character keeps its detail unless another use of the budget is worth this
	                                   ///< fraction more (0 = default 0.25; negative = none)
	uint32_t min_frames_between_switches; ///< a character keeps a new detail at least this long while the budget
	                                   ///< allows (frames; 0 = default 30)
	uint32_t crossfade_frames;         ///< frames a switch blends from the old detail to the new (0 = default 8)
	uint32_t character_capacity;       ///< the most characters at once (0 = default 64); everything is allocated at
	                                   ///< creation and plScene_AddCharacter (one instance per tier per character)
	plGpuMode gpu_mode;                ///< PLEAT_GPU_MODE_NONE (default): every detail on the CPU. A GPU mode: every
	                                   ///< tier also as a GPU detail (its networks and deformation on the GPU,
	                                   ///< PLEAT_MLP_BACKEND_GPU; a second instance per tier per character, sharing the
	                                   ///< tier's GPU data), and the policy places each character on either device
	                                   ///< within both budgets (docs/scene-budget.md, "Two devices")
	const float* tier_gpu_cost_us;     ///< [tier_count] GPU µs per character for a step with the networks (required
	                                   ///< with a GPU mode: measure it, scripts/gpu-bench.sh)
	const float* tier_gpu_skin_cost_us; ///< [tier_count] GPU µs between network updates; NULL = tier_gpu_cost_us
	const float* tier_gpu_cpu_cost_us; ///< [tier_count] CPU µs of a GPU detail (validation, forward kinematics, X_c,
	                                   ///< upload, read-back, carry-over); NULL = estimated
	float gpu_budget_us;               ///< per-frame GPU budget for the scene (µs); 0 = unlimited
	int32_t internal_cookie;           ///< set by plDefaultSceneDef; do not touch
} plSceneDef;

/// A character of a scene: the fields of plInstanceDef that every tier's instance of it shares.
typedef struct plCharacterDef
{
	const int32_t* joint_map;        ///< as plInstanceDef.joint_map (the tiers share one skeleton)
	uint32_t joint_map_count;        ///< as plInstanceDef
	uint32_t engine_joint_count;     ///< as plInstanceDef
	const float* beta;               ///< [beta_count] body shape β (unitless), NULL = zeros
	uint32_t beta_count;             ///< entries in beta
	const float* material;           ///< [4] as plInstanceDef.material, NULL = each tier's default
	float importance;                ///< initial importance (>= 0, e.g. screen coverage)
	void* user_data;                 ///< yours, returned by plScene_GetCharacterUserData
	int32_t internal_cookie;         ///< set by plDefaultCharacterDef; do not touch
} plCharacterDef;

/// What the policy planned for the last step.
typedef struct plScenePlan
{
	float cost_us;          ///< the planned per-frame cost of the scene (µs: the def's or estimated costs, times the
	                        ///< correction plScene_ReportFrameCost keeps)
	float cost_scale;       ///< that correction (1 until costs are reported)
	float budget_us;        ///< the budget it was planned for (µs; 0 = unlimited)
	float weighted_error_mm; ///< Σ importance · error / Σ importance of the planned details (mm, from the def)
	uint32_t switches;      ///< characters whose detail changed on that step
	uint32_t fading;        ///< characters cross-fading after that step
	float gpu_cost_us;      ///< the planned GPU time per frame (µs, from the def's GPU costs; 0 without a GPU mode)
	float gpu_budget_us;    ///< the GPU budget it was planned for (µs; 0 = unlimited)
	uint32_t on_gpu;        ///< characters planned on a GPU detail
} plScenePlan;

/// A scene def with defaults and the validity cookie.
PLEAT_API plSceneDef plDefaultSceneDef( void );
/// A character def with defaults and the validity cookie.
PLEAT_API plCharacterDef plDefaultCharacterDef( void );
/// Create a scene over tier assets of one context (they must outlive it). Builds the levels, their costs and errors and
/// the map from each tier's mesh to the display mesh. INVALID_DEF names the field in the log.
PLEAT_API plResult plCreateScene( plContext context, const plSceneDef* def, plScene* out_scene );
/// Destroy a scene and its characters' instances.
PLEAT_API plResult plDestroyScene( plScene scene );
/// Non-zero if the handle names a live scene.
PLEAT_API int plScene_IsValid( plScene scene );
/// Add a character (one instance per tier is created now); its id (< character_capacity) in *out_character.
/// CAPACITY_EXCEEDED when the scene is full. It starts on the policy's choice at its first plScene_Step, with no fade.
PLEAT_API plResult plScene_AddCharacter( plScene scene, const plCharacterDef* def, uint32_t* out_character );
/// Remove a character (its id may be given to a later plScene_AddCharacter).
PLEAT_API plResult plScene_RemoveCharacter( plScene scene, uint32_t character );
/// Set a character's importance (>= 0, finite; 0 = the cheapest detail whenever the budget is short).
PLEAT_API plResult plScene_SetImportance( plScene scene, uint32_t character, float importance );
/// Change the budget (µs per frame, >= 0; 0 = unlimited).
PLEAT_API plResult plScene_SetBudget( plScene scene, float budget_us );
/// Change the GPU budget (µs per frame, >= 0; 0 = unlimited) of a scene with a GPU mode (else INVALID_ARGUMENT).
PLEAT_API plResult plScene_SetGpuBudget( plScene scene, float gpu_budget_us );
/// Fix a character's detail (the policy plans the others around it), or detail = NULL to hand it back to the policy.
/// INVALID_ARGUMENT if the tier or rate is not one of the scene's, or gpu is set in a scene without a GPU mode.
PLEAT_API plResult plScene_SetOverride( plScene scene, uint32_t character, const plDetail* detail );
/// A character's current detail; during a cross-fade also the detail it fades from and how far (0..1; 1 = done).
/// out_from and out_fade may be NULL.
PLEAT_API plResult plScene_GetDetail( plScene scene, uint32_t character, plDetail* out_detail, plDetail* out_from,
									 float* out_fade );
/// Plan, switch and step every character: inputs[c] is character c's pose (as plInstance_Step's), outputs[c] its
/// destination on the display mesh (or outputs NULL), out_results[c] its result (or NULL); count must exceed the
/// highest live character id (entries of free ids are not read). Returns the first error in id order, else the first
/// note, else OK. A character whose input is rejected keeps its last outputs.
PLEAT_API plResult plScene_Step( plScene scene, const plFrameInput* inputs, const plStepOutput* outputs,
								 plResult* out_results, uint32_t count );
/// The last step's plan.
PLEAT_API plResult plScene_GetPlan( plScene scene, plScenePlan* out_plan );
/// Tell the scene what its last plScene_Step really cost (µs, measured by the engine on its own clock, > 0): the
/// scene keeps a running correction of its cost model (the ratio of the measured and the modelled costs, each a
/// running mean over ~20 frames; within ×0.25..4)
/// and plans the next frames with it, so the budget holds on the machine it runs on even when the def's costs were
/// measured elsewhere or the load changes. Never called: the def's costs are taken as they are.
PLEAT_API plResult plScene_ReportFrameCost( plScene scene, float measured_us );
/// A character's last outputs on the display mesh, [N][3] positions (metres) / unit normals, owned by the scene, valid
/// until its next step or removal (before its first step: the shaped rest template of tiers[0]).
PLEAT_API plResult plScene_GetPositions( plScene scene, uint32_t character, const float** out_positions,
										 uint32_t* out_count );
PLEAT_API plResult plScene_GetNormals( plScene scene, uint32_t character, const float** out_normals,
									   uint32_t* out_count );
/// Copy a character's skinning matrices of its last step, [J][3][4] row-major (rest space → output space, metres), as
/// plInstance_GetSkinMatrices: what the engine skins the body with. joint_count must be the tiers' J.
PLEAT_API plResult plScene_GetSkinMatrices( plScene scene, uint32_t character, float* out, uint32_t joint_count );
/// The def's user_data of a character, in *out_user_data.
PLEAT_API plResult plScene_GetCharacterUserData( plScene scene, uint32_t character, void** out_user_data );

#ifdef __cplusplus
}
#endif

#endif // PLEAT_H
