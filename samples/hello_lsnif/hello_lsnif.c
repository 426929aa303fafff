/* hello_lsnif.c -- the smallest complete LSNIF application, in C11 against the installed package
 * (lsnif/lsnif.h, liblsnif_vk): it creates its own Vulkan 1.2 instance and device with what LSNIF
 * needs, loads an .lsnif model, places one instance of it above a triangle ground quad in one TLAS,
 * traces one camera ray per pixel through a ray-tracing pipeline whose LSNIF hit group uses the
 * library's intersection shader, and writes the picture (binary PPM) and, optionally, every pixel's
 * hit record.
 *
 *   hello_lsnif MODEL.lsnif [-o image.ppm] [--hits hits.bin] [--width W] [--height H]
 *               [--device NAME] [--validate]
 *
 * The scene, exactly (a CPU reference reproduces it; tests/package does):
 *   model      bounds lo, hi (lsnifGetModelProperties), c = (lo + hi) / 2, e = hi - lo,
 *              s = max(e.x, e.y, e.z)
 *   LSNIF      instance custom index 1, SBT record offset 1, object to world
 *              x_w = A (x - c) + (0, 0.4 e.y / s, 0) with A = R diag(1.25 / s, 0.8 / s, 1 / s) and
 *              R = [[0.6, 0, 0.8], [0, 1, 0], [-0.8, 0, 0.6]] (rows; a rotation about +y): the
 *              model's box stands on y = 0, about one unit wide
 *   ground     instance custom index 0 (a hole in the model table), SBT record offset 0, identity:
 *              the quad y = -0.01, -2 <= x, z <= 2 as triangles (v0 v2 v1), (v0 v3 v2) of
 *              v0 (-2, -0.01, -2), v1 (2, -0.01, -2), v2 (2, -0.01, 2), v3 (-2, -0.01, 2)
 *   camera     eye (1.6, 1.1, 2.4) looking at (0, 0.3, 0), up +y; forward f = normalize(at - eye),
 *              right r = normalize(cross(f, +y)), u = cross(r, f); pixel (x, y) of W x H (y down)
 *              casts origin eye, direction normalize(f + a r 0.27 W / H + b u 0.27) with
 *              a = 2 (x + 0.5) / W - 1, b = 1 - 2 (y + 0.5) / H, t in [0, 100], ray flags opaque
 *   shading    linear RGB; background (0.06, 0.08, 0.12); a hit: albedo (0.25 + 0.75 max(n.L, 0)),
 *              L = (1/3, 2/3, 2/3), n the world normal; the ground's albedo is gray 0.75 where
 *              floor(4 x) + floor(4 z) is even and 0.35 where odd (x, z of the hit point), its
 *              normal +y; the LSNIF object's is the predicted albedo and normal (lsnif_hit.glsl)
 *   image      P6, 8 bits per channel: round(clamp(value, 0, 1) * 255) per channel, no gamma
 *   hits       "LSNIFHIT", uint32 width, uint32 height, then per pixel (row-major from the top)
 *              8 little-endian 32-bit values: uint kind (0 miss, 1 ground, 2 LSNIF), float t, float
 *              normal x, y, z (world), float r, g, b (the shaded value before quantization)
 *
 * hello_lsnif_engine, the same file built with HELLO_ENGINE_LAYOUT, renders the same scene the way
 * an engine with its own conventions adopts LSNIF (the same picture and hits):
 *   push constants  the application's own from offset 0, LSNIF's model table after them at byte
 *                   HELLO_LSNIF_PUSH_OFFSET (88)
 *   intersection    hello_engine.rint: LSNIF's installed source (lsnif/shaders/lsnif_intersection.glsl)
 *                   with LSNIF_MODEL_TABLE_PUSH_OFFSET 88 and LSNIF_MODEL_INDEX uint(gl_InstanceID): the
 *                   model table is indexed by the TLAS instance index (ground 0, a hole; LSNIF 1)
 *   custom index    the application's own object table: ground 5, LSNIF 9; the closest-hit shaders
 *                   read the pixel kind from it
 *   device          the application's own VkDeviceCreateInfo (core features in pEnabledFeatures, a
 *                   descriptor-indexing struct in its chain, the extensions a Vulkan 1.1 framework
 *                   enables for ray tracing) completed by lsnifEnableDeviceFeaturesInCreateInfo
 *   --vulkan-api    the instance's apiVersion, 1.1 to 1.3 (default 1.2); LSNIF needs 1.2, and with
 *                   1.1 lsnifCreateContext fails naming the instance's API version
 *
 * Every error prints a message naming the problem and exits with 1 (2 for a bad command line);
 * --validate enables VK_LAYER_KHRONOS_validation and fails (exit 1) when it reports anything
 * (warnings or errors), including at the destruction of every object. */
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <vulkan/vulkan.h>

#include <lsnif/lsnif.h>

/* The SPIR-V of hello.rgen, hello.rmiss, hello_ground.rchit and hello_lsnif.rchit (compiled at build
 * time by glslangValidator --vn). */
#include "hello_ground_rchit_spirv.h"
#include "hello_lsnif_rchit_spirv.h"
#include "hello_rgen_spirv.h"
#include "hello_rmiss_spirv.h"

#ifndef HELLO_ENGINE_LAYOUT
/* The push constants of hello_common.glsl: LSNIF's binding convention first. */
typedef struct HelloPush {
  struct LsnifRtPushConstants lsnif;
  uint64_t pixels;
  uint32_t width, height;
  float eye[4], forward[4], right[4], up[4];
} HelloPush;
_Static_assert(offsetof(HelloPush, lsnif) == LSNIF_RT_PUSH_MODEL_TABLE_OFFSET, "model table first");
_Static_assert(offsetof(HelloPush, pixels) == LSNIF_RT_PUSH_APP_OFFSET, "application's push constants after LSNIF's");
_Static_assert(sizeof(HelloPush) == 96, "std430 layout of HelloPush in hello_common.glsl");
#else
/* The push constants of hello_common.glsl with HELLO_ENGINE_LAYOUT: the application's first. */
typedef struct HelloPush {
  uint64_t pixels;
  uint32_t width, height;
  float eye[4], forward[4], right[4], up[4];
  uint64_t objects;
  struct LsnifRtPushConstants lsnif; /* the shader reads its first 12 bytes */
} HelloPush;
_Static_assert(offsetof(HelloPush, lsnif) == 88, "HELLO_LSNIF_PUSH_OFFSET of hello_common.glsl");
_Static_assert(sizeof(HelloPush) == 104, "std430 layout of HelloPush in hello_common.glsl");
#include "hello_engine_rint_spirv.h"
#endif

/* HelloPixel of hello_common.glsl. */
typedef struct HelloPixel {
  uint32_t kind;
  float t, normal[3], color[3];
} HelloPixel;
_Static_assert(sizeof(HelloPixel) == 32, "std430 layout of HelloPixel in hello_common.glsl");

enum { kKindMiss = 0, kKindGround = 1, kKindLsnif = 2 };
#ifndef HELLO_ENGINE_LAYOUT
/* The model table is indexed by the custom index: entry 0 the ground (a hole), 1 the model. */
enum { kGroundCustomIndex = 0, kLsnifCustomIndex = 1, kModelTableCount = 2 };
#else
/* The custom index is the application's (its object table of kObjectCount entries); the model table
 * is indexed by the TLAS instance index (ground 0, LSNIF 1). */
enum { kGroundCustomIndex = 5, kLsnifCustomIndex = 9, kObjectCount = 12, kModelTableCount = 2 };
#endif
enum { kGroundInstance = 0, kLsnifInstance = 1 };

typedef struct Options {
  const char* model;
  const char* image;
  const char* hits;
  const char* device;
  uint32_t width, height;
  uint32_t api_minor; /* the instance's apiVersion 1.api_minor */
  bool validate;
} Options;

typedef struct Buffer {
  VkBuffer buffer;
  VkDeviceMemory memory;
  VkDeviceAddress address;
  void* mapped; /* host-visible buffers stay mapped */
} Buffer;

typedef struct App {
  uint32_t validation_messages;
  VkInstance instance;
  VkDebugUtilsMessengerEXT messenger;
  VkPhysicalDevice physical;
  char device_name[VK_MAX_PHYSICAL_DEVICE_NAME_SIZE];
  VkPhysicalDeviceMemoryProperties memory;
  VkPhysicalDeviceRayTracingPipelinePropertiesKHR rt;
  VkPhysicalDeviceAccelerationStructurePropertiesKHR as;
  VkDevice device;
  uint32_t queue_family;
  VkQueue queue;
  VkCommandPool pool;
  VkFence fence;
  LsnifContext lsnif;
  LsnifModel model;
  Buffer vertices, indices, instances, model_table, objects, blas_storage, tlas_storage, scratch, sbt, pixels;
  VkAccelerationStructureKHR blas, tlas;
  VkDescriptorSetLayout set_layout;
  VkDescriptorPool descriptor_pool;
  VkDescriptorSet descriptor_set;
  VkPipelineLayout pipeline_layout;
  VkPipeline pipeline;
  VkStridedDeviceAddressRegionKHR raygen_region, miss_region, hit_region, callable_region;
  HelloPush push;
  /* Extension functions (not exported by the loader). */
  PFN_vkCreateDebugUtilsMessengerEXT vkCreateDebugUtilsMessengerEXT;
  PFN_vkDestroyDebugUtilsMessengerEXT vkDestroyDebugUtilsMessengerEXT;
  PFN_vkGetAccelerationStructureBuildSizesKHR vkGetAccelerationStructureBuildSizesKHR;
  PFN_vkCreateAccelerationStructureKHR vkCreateAccelerationStructureKHR;
  PFN_vkDestroyAccelerationStructureKHR vkDestroyAccelerationStructureKHR;
  PFN_vkGetAccelerationStructureDeviceAddressKHR vkGetAccelerationStructureDeviceAddressKHR;
  PFN_vkCmdBuildAccelerationStructuresKHR vkCmdBuildAccelerationStructuresKHR;
  PFN_vkCreateRayTracingPipelinesKHR vkCreateRayTracingPipelinesKHR;
  PFN_vkGetRayTracingShaderGroupHandlesKHR vkGetRayTracingShaderGroupHandlesKHR;
  PFN_vkCmdTraceRaysKHR vkCmdTraceRaysKHR;
} App;

/* ---- errors ---------------------------------------------------------------------------------- */

static int fail(const char* format, ...) {
  va_list args;
  va_start(args, format);
  fputs("hello_lsnif: ", stderr);
  vfprintf(stderr, format, args);
  fputc('\n', stderr);
  va_end(args);
  return 1;
}

#define VK_CHECK(call)                                                                     \
  do {                                                                                     \
    const VkResult vk_check_result = (call);                                               \
    if (vk_check_result != VK_SUCCESS)                                                     \
      return fail("%s failed (VkResult %d)", #call, (int)vk_check_result);                \
  } while (0)

#define LSNIF_CHECK(call)                                                                  \
  do {                                                                                     \
    const LsnifResult lsnif_check_result = (call);                                         \
    if (lsnif_check_result != LSNIF_SUCCESS)                                               \
      return fail("%s failed (%s): %s", #call, lsnifResultString(lsnif_check_result),      \
                  lsnifGetLastErrorMessage());                                             \
  } while (0)

/* Loads a function through vkGet*ProcAddr into `dst` or fails naming it. */
#define LOAD_INSTANCE(app, name)                                                                  \
  do {                                                                                            \
    (app)->name = (PFN_##name)vkGetInstanceProcAddr((app)->instance, #name);                      \
    if (!(app)->name) return fail("the instance does not provide %s", #name);                     \
  } while (0)
#define LOAD_DEVICE(app, name)                                                                    \
  do {                                                                                            \
    (app)->name = (PFN_##name)vkGetDeviceProcAddr((app)->device, #name);                          \
    if (!(app)->name) return fail("the device does not provide %s", #name);                       \
  } while (0)

static VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                            VkDebugUtilsMessageTypeFlagsEXT types,
                                                            const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                            void* user) {
  (void)types;
  App* app = (App*)user;
  ++app->validation_messages;
  fprintf(stderr, "hello_lsnif: validation %s: %s\n",
          severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? "error" : "warning", data->pMessage);
  return VK_FALSE;
}

/* ---- command line ---------------------------------------------------------------------------- */

static const char kUsage[] =
    "usage: hello_lsnif MODEL.lsnif [-o image.ppm] [--hits hits.bin] [--width W] [--height H]\n"
    "                   [--device NAME] [--vulkan-api 1.1|1.2|1.3] [--validate]\n"
    "  -o PATH        the picture, binary PPM (default hello_lsnif.ppm)\n"
    "  --hits PATH    every pixel's hit record (format: the header of hello_lsnif.c)\n"
    "  --width W      image width (default 160)\n"
    "  --height H     image height (default 120)\n"
    "  --device NAME  the first Vulkan device whose name contains NAME (default: the first device)\n"
    "  --vulkan-api V the instance's apiVersion (default 1.2; LSNIF needs 1.2 or newer)\n"
    "  --validate     enable VK_LAYER_KHRONOS_validation; any message it reports fails the run\n";

static bool parse_size(const char* text, uint32_t* out) {
  char* end = NULL;
  const unsigned long v = strtoul(text, &end, 10);
  if (!*text || *end || v == 0 || v > 8192) return false;
  *out = (uint32_t)v;
  return true;
}

/* 0: run; 1: --help printed; 2: error printed. */
static int parse_options(int argc, char** argv, Options* o) {
  o->image = "hello_lsnif.ppm";
  o->width = 160;
  o->height = 120;
  o->api_minor = 2;
  for (int i = 1; i < argc; ++i) {
    const char* a = argv[i];
    const bool has_value = i + 1 < argc;
    if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
      fputs(kUsage, stdout);
      return 1;
    } else if (!strcmp(a, "--validate")) {
      o->validate = true;
    } else if ((!strcmp(a, "-o") || !strcmp(a, "--hits") || !strcmp(a, "--device")) && has_value) {
      const char* v = argv[++i];
      if (!strcmp(a, "-o")) o->image = v;
      else if (!strcmp(a, "--hits")) o->hits = v;
      else o->device = v;
    } else if (!strcmp(a, "--vulkan-api") && has_value) {
      const char* v = argv[++i];
      if (strcmp(v, "1.1") && strcmp(v, "1.2") && strcmp(v, "1.3")) {
        fprintf(stderr, "hello_lsnif: --vulkan-api needs 1.1, 1.2 or 1.3, got '%s'\n%s", v, kUsage);
        return 2;
      }
      o->api_minor = (uint32_t)(v[2] - '0');
    } else if ((!strcmp(a, "--width") || !strcmp(a, "--height")) && has_value) {
      if (!parse_size(argv[++i], !strcmp(a, "--width") ? &o->width : &o->height)) {
        fprintf(stderr, "hello_lsnif: %s needs an integer in [1, 8192], got '%s'\n%s", a, argv[i], kUsage);
        return 2;
      }
    } else if (a[0] == '-') {
      fprintf(stderr, "hello_lsnif: unknown option or missing value: %s\n%s", a, kUsage);
      return 2;
    } else if (!o->model) {
      o->model = a;
    } else {
      fprintf(stderr, "hello_lsnif: more than one model given ('%s', '%s')\n%s", o->model, a, kUsage);
      return 2;
    }
  }
  if (!o->model) {
    fprintf(stderr, "hello_lsnif: no model given\n%s", kUsage);
    return 2;
  }
  return 0;
}

/* ---- instance, device, LSNIF context -------------------------------------------------------- */

static int create_instance(App* app, const Options* o) {
  const char* layer = "VK_LAYER_KHRONOS_validation";
  const char* extension = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  if (o->validate) {
    uint32_t count = 0;
    VK_CHECK(vkEnumerateInstanceLayerProperties(&count, NULL));
    VkLayerProperties* layers = calloc(count ? count : 1, sizeof *layers);
    if (!layers) return fail("out of memory");
    VkResult r = vkEnumerateInstanceLayerProperties(&count, layers);
    bool found = false;
    for (uint32_t i = 0; r == VK_SUCCESS && i < count; ++i) found |= !strcmp(layers[i].layerName, layer);
    free(layers);
    VK_CHECK(r);
    if (!found) return fail("--validate: %s is not installed (Debian: vulkan-validationlayers)", layer);
  }
  VkDebugUtilsMessengerCreateInfoEXT messenger = {.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  messenger.messageSeverity =
      VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messenger.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                          VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messenger.pfnUserCallback = on_validation_message;
  messenger.pUserData = app;

  VkApplicationInfo application = {.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO};
  application.pApplicationName = "hello_lsnif";
  application.apiVersion = VK_MAKE_API_VERSION(0, 1, o->api_minor, 0);
  VkInstanceCreateInfo info = {.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  info.pApplicationInfo = &application;
  if (o->validate) {
    info.pNext = &messenger; /* also covers vkCreateInstance and vkDestroyInstance */
    info.enabledLayerCount = 1;
    info.ppEnabledLayerNames = &layer;
    info.enabledExtensionCount = 1;
    info.ppEnabledExtensionNames = &extension;
  }
  VK_CHECK(vkCreateInstance(&info, NULL, &app->instance));
  if (o->validate) {
    LOAD_INSTANCE(app, vkCreateDebugUtilsMessengerEXT);
    LOAD_INSTANCE(app, vkDestroyDebugUtilsMessengerEXT);
    VK_CHECK(app->vkCreateDebugUtilsMessengerEXT(app->instance, &messenger, NULL, &app->messenger));
  }
  return 0;
}

/* The first device whose name contains o->device (any device without --device), which must offer
 * what LSNIF needs (lsnifQueryDeviceSupport; hello_lsnif_engine leaves the check to
 * lsnifCreateContext, as a framework that picks its device itself), and its first queue family
 * with compute. */
static int pick_device(App* app, const Options* o) {
  uint32_t count = 0;
  VK_CHECK(vkEnumeratePhysicalDevices(app->instance, &count, NULL));
  if (count == 0) return fail("no Vulkan device (is a Vulkan driver installed? Debian: mesa-vulkan-drivers)");
  VkPhysicalDevice devices[16];
  if (count > 16) count = 16;
  VkResult r = vkEnumeratePhysicalDevices(app->instance, &count, devices);
  if (r != VK_SUCCESS && r != VK_INCOMPLETE) VK_CHECK(r);
  char names[1024] = "";
  for (uint32_t i = 0; i < count && !app->physical; ++i) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(devices[i], &p);
    if (strlen(names) + strlen(p.deviceName) + 4 < sizeof names) {
      if (names[0]) strcat(names, ", ");
      strcat(names, p.deviceName);
    }
    if (o->device && !strstr(p.deviceName, o->device)) continue;
    app->physical = devices[i];
    memcpy(app->device_name, p.deviceName, sizeof app->device_name);
  }
  if (!app->physical) return fail("no Vulkan device name contains '%s' (devices: %s)", o->device, names);

#ifndef HELLO_ENGINE_LAYOUT
  LsnifDeviceSupport support;
  LSNIF_CHECK(lsnifQueryDeviceSupport(app->instance, app->physical, vkGetInstanceProcAddr, &support));
  if (!support.supported) return fail("the device '%s' lacks what LSNIF needs: %s", support.deviceName, support.missing);
#endif

  uint32_t families = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(app->physical, &families, NULL);
  VkQueueFamilyProperties props[16];
  if (families > 16) families = 16;
  vkGetPhysicalDeviceQueueFamilyProperties(app->physical, &families, props);
  app->queue_family = UINT32_MAX;
  for (uint32_t i = 0; i < families && app->queue_family == UINT32_MAX; ++i)
    if (props[i].queueFlags & VK_QUEUE_COMPUTE_BIT) app->queue_family = i;
  if (app->queue_family == UINT32_MAX) return fail("the device '%s' has no queue family with compute", app->device_name);

  vkGetPhysicalDeviceMemoryProperties(app->physical, &app->memory);
  app->rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR;
  app->as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR;
  app->rt.pNext = &app->as;
  VkPhysicalDeviceProperties2 p2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  p2.pNext = &app->rt;
  vkGetPhysicalDeviceProperties2(app->physical, &p2);
  app->rt.pNext = NULL;
  app->as.pNext = NULL;
  return 0;
}

/* The device with LSNIF's extensions and features, and the LSNIF context on it. */
static int create_device(App* app) {
  uint32_t extension_count = 0;
  const char* const* lsnif_extensions = lsnifGetRequiredDeviceExtensions(&extension_count);
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queue = {.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  queue.queueFamilyIndex = app->queue_family;
  queue.queueCount = 1;
  queue.pQueuePriorities = &priority;
  VkDeviceCreateInfo info = {.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  info.queueCreateInfoCount = 1;
  info.pQueueCreateInfos = &queue;
#ifndef HELLO_ENGINE_LAYOUT
  LsnifDeviceFeatures features;
  lsnifInitDeviceFeatures(&features, NULL); /* everything this program needs too (buffer device address, int64) */
  info.pNext = &features.features2;
  info.enabledExtensionCount = extension_count;
  info.ppEnabledExtensionNames = lsnif_extensions;
  const void* enabled_features = &features.features2;
#else
  /* The engine's own create info: its core features in pEnabledFeatures, its own feature struct in
   * the chain, and the extensions a framework written for Vulkan 1.1 enables for ray tracing beside
   * LSNIF's. lsnifEnableDeviceFeaturesInCreateInfo completes it (and says so to the context). */
  static const char* const kEngineExtensions[] = {
      VK_KHR_SPIRV_1_4_EXTENSION_NAME, VK_KHR_SHADER_FLOAT_CONTROLS_EXTENSION_NAME,
      VK_KHR_BUFFER_DEVICE_ADDRESS_EXTENSION_NAME, VK_EXT_DESCRIPTOR_INDEXING_EXTENSION_NAME};
  enum { kEngineExtensionCount = sizeof kEngineExtensions / sizeof kEngineExtensions[0] };
  const char* extensions[8];
  if (extension_count + kEngineExtensionCount > 8) return fail("LSNIF needs %u extensions", extension_count);
  for (uint32_t i = 0; i < extension_count; ++i) extensions[i] = lsnif_extensions[i];
  for (uint32_t i = 0; i < kEngineExtensionCount; ++i) extensions[extension_count + i] = kEngineExtensions[i];
  info.enabledExtensionCount = extension_count + kEngineExtensionCount;
  info.ppEnabledExtensionNames = extensions;
  const VkPhysicalDeviceFeatures core = {0}; /* the engine's own core features (none needed here) */
  VkPhysicalDeviceDescriptorIndexingFeatures indexing = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DESCRIPTOR_INDEXING_FEATURES};
  indexing.runtimeDescriptorArray = VK_TRUE;
  info.pNext = &indexing;
  info.pEnabledFeatures = &core;
  LsnifDeviceFeatureStorage lsnif_features;
  LSNIF_CHECK(lsnifEnableDeviceFeaturesInCreateInfo(&info, &lsnif_features));
  const void* enabled_features = &info;
#endif
  VK_CHECK(vkCreateDevice(app->physical, &info, NULL, &app->device));
  vkGetDeviceQueue(app->device, app->queue_family, 0, &app->queue);
  LOAD_DEVICE(app, vkGetAccelerationStructureBuildSizesKHR);
  LOAD_DEVICE(app, vkCreateAccelerationStructureKHR);
  LOAD_DEVICE(app, vkDestroyAccelerationStructureKHR);
  LOAD_DEVICE(app, vkGetAccelerationStructureDeviceAddressKHR);
  LOAD_DEVICE(app, vkCmdBuildAccelerationStructuresKHR);
  LOAD_DEVICE(app, vkCreateRayTracingPipelinesKHR);
  LOAD_DEVICE(app, vkGetRayTracingShaderGroupHandlesKHR);
  LOAD_DEVICE(app, vkCmdTraceRaysKHR);

  VkCommandPoolCreateInfo pool = {.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pool.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pool.queueFamilyIndex = app->queue_family;
  VK_CHECK(vkCreateCommandPool(app->device, &pool, NULL, &app->pool));
  VkFenceCreateInfo fence = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VK_CHECK(vkCreateFence(app->device, &fence, NULL, &app->fence));

  LsnifContextCreateInfo ci = {0};
  ci.instance = app->instance;
  ci.physicalDevice = app->physical;
  ci.device = app->device;
  ci.queueFamilyIndex = app->queue_family;
  ci.queue = app->queue;
  ci.pfnGetInstanceProcAddr = vkGetInstanceProcAddr;
  ci.pEnabledFeatures = enabled_features;
  LSNIF_CHECK(lsnifCreateContext(&ci, &app->lsnif));
  return 0;
}

/* ---- buffers and one-time commands ---------------------------------------------------------- */

/* A buffer with a device address: host-visible, coherent and mapped (holding `data` when not NULL),
 * or device-local. */
static int create_buffer(App* app, VkDeviceSize size, VkBufferUsageFlags usage, bool host, const void* data,
                         Buffer* out) {
  VkBufferCreateInfo info = {.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = size;
  info.usage = usage | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VK_CHECK(vkCreateBuffer(app->device, &info, NULL, &out->buffer));
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(app->device, out->buffer, &req);
  const VkMemoryPropertyFlags want = host ? VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT
                                          : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  uint32_t type = UINT32_MAX;
  for (uint32_t i = 0; i < app->memory.memoryTypeCount && type == UINT32_MAX; ++i)
    if ((req.memoryTypeBits & (1u << i)) && (app->memory.memoryTypes[i].propertyFlags & want) == want) type = i;
  if (type == UINT32_MAX)
    return fail("no %s memory type for a buffer of usage 0x%x", host ? "host-visible coherent" : "device-local",
                (unsigned)usage);
  VkMemoryAllocateFlagsInfo flags = {.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
  VkMemoryAllocateInfo alloc = {.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.pNext = &flags;
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = type;
  VK_CHECK(vkAllocateMemory(app->device, &alloc, NULL, &out->memory));
  VK_CHECK(vkBindBufferMemory(app->device, out->buffer, out->memory, 0));
  if (host) {
    VK_CHECK(vkMapMemory(app->device, out->memory, 0, VK_WHOLE_SIZE, 0, &out->mapped));
    if (data) memcpy(out->mapped, data, (size_t)size);
  }
  VkBufferDeviceAddressInfo address = {.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO};
  address.buffer = out->buffer;
  out->address = vkGetBufferDeviceAddress(app->device, &address);
  return 0;
}

static void destroy_buffer(App* app, Buffer* b) {
  if (b->buffer) vkDestroyBuffer(app->device, b->buffer, NULL);
  if (b->memory) vkFreeMemory(app->device, b->memory, NULL); /* unmaps */
  memset(b, 0, sizeof *b);
}

static VkDeviceSize align_up(VkDeviceSize value, VkDeviceSize alignment) {
  return (value + alignment - 1) / alignment * alignment;
}

static int begin_commands(App* app, VkCommandBuffer* cmd) {
  VkCommandBufferAllocateInfo alloc = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  alloc.commandPool = app->pool;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  VK_CHECK(vkAllocateCommandBuffers(app->device, &alloc, cmd));
  VkCommandBufferBeginInfo begin = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(*cmd, &begin));
  return 0;
}

/* Ends, submits and waits for `cmd`, then frees it. */
static int submit_and_wait(App* app, VkCommandBuffer cmd) {
  VkResult r = vkEndCommandBuffer(cmd);
  VkSubmitInfo submit = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  if (r == VK_SUCCESS) r = vkQueueSubmit(app->queue, 1, &submit, app->fence);
  if (r == VK_SUCCESS) r = vkWaitForFences(app->device, 1, &app->fence, VK_TRUE, UINT64_MAX);
  if (r == VK_SUCCESS) r = vkResetFences(app->device, 1, &app->fence);
  vkFreeCommandBuffers(app->device, app->pool, 1, &cmd);
  VK_CHECK(r);
  return 0;
}

static void barrier(VkCommandBuffer cmd, VkPipelineStageFlags src_stage, VkAccessFlags src_access,
                    VkPipelineStageFlags dst_stage, VkAccessFlags dst_access) {
  VkMemoryBarrier b = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  b.srcAccessMask = src_access;
  b.dstAccessMask = dst_access;
  vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 1, &b, 0, NULL, 0, NULL);
}

/* ---- the scene ------------------------------------------------------------------------------- */

/* Creates acceleration structure `*as` of `type` for `geometry` with `primitives` primitives (its
 * storage in `storage`) and records its build into `cmd`, using `app->scratch` (allocated by the
 * caller for the largest build) followed by a barrier for later builds and traces. */
static int record_build(App* app, VkCommandBuffer cmd, VkAccelerationStructureTypeKHR type,
                        const VkAccelerationStructureGeometryKHR* geometry, uint32_t primitives, Buffer* storage,
                        VkAccelerationStructureKHR* as, VkDeviceSize* scratch_size, bool record) {
  VkAccelerationStructureBuildGeometryInfoKHR build = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR};
  build.type = type;
  build.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR;
  build.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
  build.geometryCount = 1;
  build.pGeometries = geometry;
  VkAccelerationStructureBuildSizesInfoKHR sizes = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
  app->vkGetAccelerationStructureBuildSizesKHR(app->device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &build,
                                               &primitives, &sizes);
  if (!record) { /* first pass: the scratch size only */
    if (sizes.buildScratchSize > *scratch_size) *scratch_size = sizes.buildScratchSize;
    return 0;
  }
  if (create_buffer(app, sizes.accelerationStructureSize, VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR,
                    false, NULL, storage))
    return 1;
  VkAccelerationStructureCreateInfoKHR info = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR};
  info.buffer = storage->buffer;
  info.size = sizes.accelerationStructureSize;
  info.type = type;
  VK_CHECK(app->vkCreateAccelerationStructureKHR(app->device, &info, NULL, as));
  build.dstAccelerationStructure = *as;
  build.scratchData.deviceAddress =
      align_up(app->scratch.address, app->as.minAccelerationStructureScratchOffsetAlignment);
  VkAccelerationStructureBuildRangeInfoKHR range = {0};
  range.primitiveCount = primitives;
  const VkAccelerationStructureBuildRangeInfoKHR* ranges = &range;
  app->vkCmdBuildAccelerationStructuresKHR(cmd, 1, &build, &ranges);
  /* The next build reuses the scratch buffer and may read this structure; the trace reads it. */
  barrier(cmd, VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR, VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR,
          VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR | VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR,
          VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR | VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR);
  return 0;
}

static VkDeviceAddress as_address(App* app, VkAccelerationStructureKHR as) {
  VkAccelerationStructureDeviceAddressInfoKHR info = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR};
  info.accelerationStructure = as;
  return app->vkGetAccelerationStructureDeviceAddressKHR(app->device, &info);
}

/* The LSNIF instance's object-to-world transform (the header's formula). */
static VkTransformMatrixKHR lsnif_transform(const LsnifModelProperties* p) {
  static const float kRotation[3][3] = {{0.6f, 0.0f, 0.8f}, {0.0f, 1.0f, 0.0f}, {-0.8f, 0.0f, 0.6f}};
  float c[3], e[3];
  for (int k = 0; k < 3; ++k) {
    c[k] = 0.5f * (p->boundsMin[k] + p->boundsMax[k]);
    e[k] = p->boundsMax[k] - p->boundsMin[k];
  }
  const float s = fmaxf(e[0], fmaxf(e[1], e[2]));
  const float scale[3] = {1.25f / s, 0.8f / s, 1.0f / s};
  VkTransformMatrixKHR m;
  for (int r = 0; r < 3; ++r) {
    float t = r == 1 ? 0.4f * e[1] / s : 0.0f;
    for (int k = 0; k < 3; ++k) {
      m.matrix[r][k] = kRotation[r][k] * scale[k];
      t -= m.matrix[r][k] * c[k];
    }
    m.matrix[r][3] = t;
  }
  return m;
}

/* The model (loaded and built by LSNIF), the ground's BLAS, the TLAS of both instances and the
 * model table. */
static int build_scene(App* app, const Options* o) {
  LSNIF_CHECK(lsnifCreateModelFromFile(app->lsnif, o->model, &app->model));
  LSNIF_CHECK(lsnifBuildModels(app->lsnif, 1, &app->model));
  LsnifModelProperties props;
  LSNIF_CHECK(lsnifGetModelProperties(app->lsnif, app->model, &props));

#ifndef HELLO_ENGINE_LAYOUT
  /* The model table: entry kLsnifCustomIndex is the model, entry kGroundCustomIndex a hole. */
  const LsnifModel table_models[kModelTableCount] = {[kGroundCustomIndex] = NULL, [kLsnifCustomIndex] = app->model};
#else
  /* The model table: entry kLsnifInstance (the TLAS instance index) is the model, kGroundInstance a
   * hole; the application's object table, indexed by the custom index, holds each object's pixel
   * kind (the other entries are not kinds, so a wrong index shows). */
  const LsnifModel table_models[kModelTableCount] = {[kGroundInstance] = NULL, [kLsnifInstance] = app->model};
  uint32_t objects[kObjectCount];
  for (uint32_t i = 0; i < kObjectCount; ++i) objects[i] = 0xBADu;
  objects[kGroundCustomIndex] = kKindGround;
  objects[kLsnifCustomIndex] = kKindLsnif;
  if (create_buffer(app, sizeof objects, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, objects, &app->objects)) return 1;
#endif
  uint64_t table[kModelTableCount];
  LSNIF_CHECK(lsnifWriteModelTable(app->lsnif, kModelTableCount, table_models, table));
  if (create_buffer(app, sizeof table, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, table, &app->model_table)) return 1;

  const float g = -0.01f;
  const float vertices[4][3] = {{-2.0f, g, -2.0f}, {2.0f, g, -2.0f}, {2.0f, g, 2.0f}, {-2.0f, g, 2.0f}};
  const uint32_t indices[6] = {0, 2, 1, 0, 3, 2};
  const VkBufferUsageFlags input = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR;
  if (create_buffer(app, sizeof vertices, input, true, vertices, &app->vertices)) return 1;
  if (create_buffer(app, sizeof indices, input, true, indices, &app->indices)) return 1;

  VkAccelerationStructureInstanceKHR instances[2]; /* [kGroundInstance], [kLsnifInstance] */
  memset(instances, 0, sizeof instances);
  VkAccelerationStructureGeometryKHR ground = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR};
  ground.geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR;
  ground.flags = VK_GEOMETRY_OPAQUE_BIT_KHR;
  ground.geometry.triangles.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR;
  ground.geometry.triangles.vertexFormat = VK_FORMAT_R32G32B32_SFLOAT;
  ground.geometry.triangles.vertexData.deviceAddress = app->vertices.address;
  ground.geometry.triangles.vertexStride = sizeof vertices[0];
  ground.geometry.triangles.maxVertex = 3;
  ground.geometry.triangles.indexType = VK_INDEX_TYPE_UINT32;
  ground.geometry.triangles.indexData.deviceAddress = app->indices.address;
  VkAccelerationStructureGeometryKHR tlas = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR};
  tlas.geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR;
  tlas.geometry.instances.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR;
  tlas.geometry.instances.arrayOfPointers = VK_FALSE;

  /* Pass 0 sizes the shared scratch buffer, pass 1 records both builds. */
  VkDeviceSize scratch = 0;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  for (int pass = 0; pass < 2; ++pass) {
    const bool record = pass == 1;
    if (record) {
      if (create_buffer(app, scratch + app->as.minAccelerationStructureScratchOffsetAlignment,
                        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, false, NULL, &app->scratch))
        return 1;
      if (begin_commands(app, &cmd)) return 1;
    }
    if (record_build(app, cmd, VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, &ground, 2, &app->blas_storage,
                     &app->blas, &scratch, record))
      return 1;
    if (record) {
      VkAccelerationStructureInstanceKHR* quad = &instances[kGroundInstance];
      quad->transform.matrix[0][0] = quad->transform.matrix[1][1] = quad->transform.matrix[2][2] = 1.0f;
      quad->instanceCustomIndex = kGroundCustomIndex;
      quad->mask = 0xFF;
      quad->instanceShaderBindingTableRecordOffset = 0;
      quad->accelerationStructureReference = as_address(app, app->blas);
      LsnifInstanceInfo info = {0};
      info.model = app->model;
      info.transform = lsnif_transform(&props);
      info.instanceCustomIndex = kLsnifCustomIndex;
      info.mask = 0xFF;
      info.instanceShaderBindingTableRecordOffset = 1;
      LSNIF_CHECK(lsnifMakeInstance(app->lsnif, &info, &instances[kLsnifInstance]));
      if (create_buffer(app, sizeof instances, VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR,
                        true, instances, &app->instances))
        return 1;
      tlas.geometry.instances.data.deviceAddress = app->instances.address;
    }
    if (record_build(app, cmd, VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, &tlas, 2, &app->tlas_storage, &app->tlas,
                     &scratch, record))
      return 1;
  }
  return submit_and_wait(app, cmd);
}

/* ---- pipeline, shader binding table, trace -------------------------------------------------- */

static int create_module(App* app, const uint32_t* code, size_t bytes, VkShaderModule* out) {
  VkShaderModuleCreateInfo info = {.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = bytes;
  info.pCode = code;
  VK_CHECK(vkCreateShaderModule(app->device, &info, NULL, out));
  return 0;
}

static const VkShaderStageFlags kPushStages =
    VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR | VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR |
    VK_SHADER_STAGE_INTERSECTION_BIT_KHR;

/* Stages: raygen, miss, ground closest hit, LSNIF closest hit, LSNIF intersection. Groups: raygen,
 * miss, hit group 0 (triangles: ground), hit group 1 (procedural: LSNIF). */
static int create_pipeline(App* app) {
  VkDescriptorSetLayoutBinding binding = {0};
  binding.binding = 0;
  binding.descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
  binding.descriptorCount = 1;
  binding.stageFlags = VK_SHADER_STAGE_RAYGEN_BIT_KHR;
  VkDescriptorSetLayoutCreateInfo set_layout = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  set_layout.bindingCount = 1;
  set_layout.pBindings = &binding;
  VK_CHECK(vkCreateDescriptorSetLayout(app->device, &set_layout, NULL, &app->set_layout));
  const VkPushConstantRange push = {kPushStages, 0, sizeof(HelloPush)};
  VkPipelineLayoutCreateInfo layout = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layout.setLayoutCount = 1;
  layout.pSetLayouts = &app->set_layout;
  layout.pushConstantRangeCount = 1;
  layout.pPushConstantRanges = &push;
  VK_CHECK(vkCreatePipelineLayout(app->device, &layout, NULL, &app->pipeline_layout));

  const VkDescriptorPoolSize size = {VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 1};
  VkDescriptorPoolCreateInfo pool = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pool.maxSets = 1;
  pool.poolSizeCount = 1;
  pool.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(app->device, &pool, NULL, &app->descriptor_pool));
  VkDescriptorSetAllocateInfo alloc = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = app->descriptor_pool;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &app->set_layout;
  VK_CHECK(vkAllocateDescriptorSets(app->device, &alloc, &app->descriptor_set));
  VkWriteDescriptorSetAccelerationStructureKHR as_write = {
      .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR};
  as_write.accelerationStructureCount = 1;
  as_write.pAccelerationStructures = &app->tlas;
  VkWriteDescriptorSet write = {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  write.pNext = &as_write;
  write.dstSet = app->descriptor_set;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
  vkUpdateDescriptorSets(app->device, 1, &write, 0, NULL);

#ifndef HELLO_ENGINE_LAYOUT
  /* The library's intersection shader for its default layout. */
  const uint32_t* rint = NULL;
  size_t rint_bytes = 0;
  LSNIF_CHECK(lsnifGetIntersectionShaderSpirv(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE, &rint, &rint_bytes));
#else
  /* LSNIF's intersection shader built for this layout (hello_engine.rint). */
  const uint32_t* rint = hello_engine_rint_spirv;
  const size_t rint_bytes = sizeof hello_engine_rint_spirv;
#endif
  enum { kStages = 5 };
  const struct {
    const uint32_t* code;
    size_t bytes;
    VkShaderStageFlagBits stage;
  } sources[kStages] = {
      {hello_rgen_spirv, sizeof hello_rgen_spirv, VK_SHADER_STAGE_RAYGEN_BIT_KHR},
      {hello_rmiss_spirv, sizeof hello_rmiss_spirv, VK_SHADER_STAGE_MISS_BIT_KHR},
      {hello_ground_rchit_spirv, sizeof hello_ground_rchit_spirv, VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR},
      {hello_lsnif_rchit_spirv, sizeof hello_lsnif_rchit_spirv, VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR},
      {rint, rint_bytes, VK_SHADER_STAGE_INTERSECTION_BIT_KHR},
  };
  VkPipelineShaderStageCreateInfo stages[kStages];
  memset(stages, 0, sizeof stages);
  int status = 0;
  for (int i = 0; i < kStages && !status; ++i) {
    stages[i].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[i].stage = sources[i].stage;
    stages[i].pName = "main";
    status = create_module(app, sources[i].code, sources[i].bytes, &stages[i].module);
  }
  VkRayTracingShaderGroupCreateInfoKHR groups[4];
  for (int i = 0; i < 4; ++i) {
    memset(&groups[i], 0, sizeof groups[i]);
    groups[i].sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR;
    groups[i].generalShader = groups[i].closestHitShader = VK_SHADER_UNUSED_KHR;
    groups[i].anyHitShader = groups[i].intersectionShader = VK_SHADER_UNUSED_KHR;
  }
  groups[0].type = groups[1].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR;
  groups[0].generalShader = 0;
  groups[1].generalShader = 1;
  groups[2].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR;
  groups[2].closestHitShader = 2;
  groups[3].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_PROCEDURAL_HIT_GROUP_KHR;
  groups[3].closestHitShader = 3;
  groups[3].intersectionShader = 4;
  VkRayTracingPipelineCreateInfoKHR info = {.sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR};
  info.stageCount = kStages;
  info.pStages = stages;
  info.groupCount = 4;
  info.pGroups = groups;
  info.maxPipelineRayRecursionDepth = 1;
  info.layout = app->pipeline_layout;
  VkResult r = VK_SUCCESS;
  if (!status)
    r = app->vkCreateRayTracingPipelinesKHR(app->device, VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &info, NULL, &app->pipeline);
  for (int i = 0; i < kStages; ++i)
    if (stages[i].module) vkDestroyShaderModule(app->device, stages[i].module, NULL);
  if (status) return status;
  VK_CHECK(r);

  /* The shader binding table: raygen, miss, the two hit groups, each region at a multiple of
   * shaderGroupBaseAlignment from a base-aligned start. */
  const VkDeviceSize handle = app->rt.shaderGroupHandleSize;
  const VkDeviceSize base = app->rt.shaderGroupBaseAlignment;
  const VkDeviceSize stride = align_up(handle, app->rt.shaderGroupHandleAlignment);
  const VkDeviceSize region = align_up(stride, base);
  const VkDeviceSize hit_bytes = align_up(2 * stride, base);
  uint8_t handles[4 * 64];
  if (handle > 64) return fail("shader group handles of %u bytes (at most 64 handled)", (unsigned)handle);
  VK_CHECK(app->vkGetRayTracingShaderGroupHandlesKHR(app->device, app->pipeline, 0, 4, (size_t)(4 * handle), handles));
  if (create_buffer(app, 2 * region + hit_bytes + base, VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR, true, NULL,
                    &app->sbt))
    return 1;
  const VkDeviceAddress start = align_up(app->sbt.address, base);
  uint8_t* mapped = (uint8_t*)app->sbt.mapped + (start - app->sbt.address);
  memcpy(mapped, handles, (size_t)handle);
  memcpy(mapped + region, handles + handle, (size_t)handle);
  memcpy(mapped + 2 * region, handles + 2 * handle, (size_t)handle);
  memcpy(mapped + 2 * region + stride, handles + 3 * handle, (size_t)handle);
  app->raygen_region = (VkStridedDeviceAddressRegionKHR){start, region, region};
  app->miss_region = (VkStridedDeviceAddressRegionKHR){start + region, stride, stride};
  app->hit_region = (VkStridedDeviceAddressRegionKHR){start + 2 * region, stride, 2 * stride};
  return 0;
}

static void normalize3(float v[3]) {
  const float len = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  for (int k = 0; k < 3; ++k) v[k] /= len;
}

/* The camera of the header comment. */
static void set_camera(HelloPush* p) {
  static const float kEye[3] = {1.6f, 1.1f, 2.4f}, kAt[3] = {0.0f, 0.3f, 0.0f}, kTanHalfFov = 0.27f;
  float f[3], r[3], u[3];
  for (int k = 0; k < 3; ++k) f[k] = kAt[k] - kEye[k];
  normalize3(f);
  r[0] = -f[2]; /* cross(f, +y) */
  r[1] = 0.0f;
  r[2] = f[0];
  normalize3(r);
  u[0] = r[1] * f[2] - r[2] * f[1];
  u[1] = r[2] * f[0] - r[0] * f[2];
  u[2] = r[0] * f[1] - r[1] * f[0];
  const float aspect = (float)p->width / (float)p->height;
  for (int k = 0; k < 3; ++k) {
    p->eye[k] = kEye[k];
    p->forward[k] = f[k];
    p->right[k] = r[k] * kTanHalfFov * aspect;
    p->up[k] = u[k] * kTanHalfFov;
  }
}

static int trace(App* app, const Options* o) {
  const VkDeviceSize bytes = (VkDeviceSize)o->width * o->height * sizeof(HelloPixel);
  if (create_buffer(app, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, NULL, &app->pixels)) return 1;
  HelloPush* p = &app->push;
#ifdef HELLO_ENGINE_LAYOUT
  p->objects = app->objects.address;
#endif
  p->lsnif.model_table = app->model_table.address;
  p->lsnif.model_count = kModelTableCount;
  p->pixels = app->pixels.address;
  p->width = o->width;
  p->height = o->height;
  set_camera(p);
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (begin_commands(app, &cmd)) return 1;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, app->pipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, app->pipeline_layout, 0, 1,
                          &app->descriptor_set, 0, NULL);
  vkCmdPushConstants(cmd, app->pipeline_layout, kPushStages, 0, sizeof *p, p);
  app->vkCmdTraceRaysKHR(cmd, &app->raygen_region, &app->miss_region, &app->hit_region, &app->callable_region,
                         o->width, o->height, 1);
  barrier(cmd, VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
          VK_ACCESS_HOST_READ_BIT);
  return submit_and_wait(app, cmd);
}

/* ---- output ---------------------------------------------------------------------------------- */

static uint8_t quantize(float v) {
  const float c = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
  return (uint8_t)(c * 255.0f + 0.5f);
}

static int write_outputs(const App* app, const Options* o) {
  const HelloPixel* pixels = (const HelloPixel*)app->pixels.mapped;
  const size_t n = (size_t)o->width * o->height;
  FILE* f = fopen(o->image, "wb");
  if (!f) return fail("cannot write %s", o->image);
  bool ok = fprintf(f, "P6\n%u %u\n255\n", o->width, o->height) > 0;
  for (size_t i = 0; i < n && ok; ++i) {
    const uint8_t rgb[3] = {quantize(pixels[i].color[0]), quantize(pixels[i].color[1]), quantize(pixels[i].color[2])};
    ok = fwrite(rgb, 1, 3, f) == 3;
  }
  ok = fclose(f) == 0 && ok;
  if (!ok) return fail("writing %s failed", o->image);
  if (o->hits) {
    f = fopen(o->hits, "wb");
    if (!f) return fail("cannot write %s", o->hits);
    const uint32_t size[2] = {o->width, o->height};
    ok = fwrite("LSNIFHIT", 1, 8, f) == 8 && fwrite(size, sizeof size, 1, f) == 1 &&
         fwrite(pixels, sizeof *pixels, n, f) == n;
    ok = fclose(f) == 0 && ok;
    if (!ok) return fail("writing %s failed", o->hits);
  }
  size_t kinds[3] = {0, 0, 0};
  for (size_t i = 0; i < n; ++i)
    if (pixels[i].kind < 3) ++kinds[pixels[i].kind];
  printf("hello_lsnif: %ux%u on %s: %zu LSNIF, %zu ground, %zu background pixels; wrote %s%s%s\n", o->width,
         o->height, app->device_name, kinds[kKindLsnif], kinds[kKindGround], kinds[kKindMiss], o->image,
         o->hits ? " and " : "", o->hits ? o->hits : "");
  return 0;
}

/* Destroys whatever was created, children first. */
static void destroy_all(App* app) {
  if (app->device) {
    vkDeviceWaitIdle(app->device);
    if (app->pipeline) vkDestroyPipeline(app->device, app->pipeline, NULL);
    if (app->pipeline_layout) vkDestroyPipelineLayout(app->device, app->pipeline_layout, NULL);
    if (app->descriptor_pool) vkDestroyDescriptorPool(app->device, app->descriptor_pool, NULL);
    if (app->set_layout) vkDestroyDescriptorSetLayout(app->device, app->set_layout, NULL);
    if (app->tlas) app->vkDestroyAccelerationStructureKHR(app->device, app->tlas, NULL);
    if (app->blas) app->vkDestroyAccelerationStructureKHR(app->device, app->blas, NULL);
    Buffer* buffers[] = {&app->vertices,     &app->indices, &app->instances, &app->model_table, &app->objects,
                         &app->blas_storage, &app->tlas_storage, &app->scratch, &app->sbt, &app->pixels};
    for (size_t i = 0; i < sizeof buffers / sizeof buffers[0]; ++i) destroy_buffer(app, buffers[i]);
    lsnifDestroyContext(app->lsnif); /* and the model */
    if (app->fence) vkDestroyFence(app->device, app->fence, NULL);
    if (app->pool) vkDestroyCommandPool(app->device, app->pool, NULL);
    vkDestroyDevice(app->device, NULL);
  }
  if (app->messenger) app->vkDestroyDebugUtilsMessengerEXT(app->instance, app->messenger, NULL);
  if (app->instance) vkDestroyInstance(app->instance, NULL);
}

int main(int argc, char** argv) {
  Options options = {0};
  const int parsed = parse_options(argc, argv, &options);
  if (parsed) return parsed == 1 ? 0 : 2;
  /* The library's ABI changes only with its major version (SONAME liblsnif_vk.so.MAJOR). */
  const uint32_t version = lsnifGetVersion();
  if (LSNIF_VERSION_GET_MAJOR(version) != LSNIF_VERSION_MAJOR)
    return fail("liblsnif_vk is version %u.%u.%u, these headers are %s (major versions differ)",
                LSNIF_VERSION_GET_MAJOR(version), LSNIF_VERSION_GET_MINOR(version), LSNIF_VERSION_GET_PATCH(version),
                LSNIF_VERSION_STRING);
  App* app = calloc(1, sizeof *app);
  if (!app) return fail("out of memory");
  int status = create_instance(app, &options);
  if (!status) status = pick_device(app, &options);
  if (!status) status = create_device(app);
  if (!status) status = build_scene(app, &options);
  if (!status) status = create_pipeline(app);
  if (!status) status = trace(app, &options);
  if (!status) status = write_outputs(app, &options);
  destroy_all(app);
  if (app->validation_messages) {
    fail("the validation layer reported %u message(s) (above)", app->validation_messages);
    status = 1;
  }
  free(app);
  return status;
}
