// Placeholder so the library has a translation unit; replaced by the renderer (issue #6).
namespace cascade::render { int placeholder = 0; }
