/* own_headers.h -- the consumer's headers by their bare names, each checked to be its own. */
#ifndef CONSUMER_OWN_HEADERS_H
#define CONSUMER_OWN_HEADERS_H
#include "config.h"
#include "host_device.h"
#include "mesh.h"
#include "model.h"
#include "status.h"
#if !defined(CONSUMER_OWN_CONFIG) || !defined(CONSUMER_OWN_STATUS) || !defined(CONSUMER_OWN_MESH) || \
    !defined(CONSUMER_OWN_MODEL) || !defined(CONSUMER_OWN_HOST_DEVICE)
#error "a header of LSNIF shadows one of the consumer's own"
#endif
#endif
