// ivoct export/ — the indexes of partitioned outputs (the build over MPI): a
// .pvtu over .vtu pieces, a .phtg over .htg pieces, and the cell list's .pcsv
// over CSV pieces.  No VTK here: a .pvtu is a short XML file naming the pieces
// and declaring their arrays, and those declarations are copied from a piece's
// own header, so the index cannot drift from what exp_vtu writes; a .phtg
// names the pieces only (VTK 9.1's reader reads nothing else from it).
#include <cstring>
#include <string>

#include "internal.hpp"

namespace {

// The value of attribute `name` in the XML start tag `tag` ("" when absent).
std::string attribute(const std::string &tag, const char *name)
{
    std::string key = std::string(" ") + name + "=\"";
    size_t at = tag.find(key);
    if (at == std::string::npos)
        return "";
    at += key.size();
    size_t end = tag.find('"', at);
    return end == std::string::npos ? "" : tag.substr(at, end - at);
}

// The beginning of a VTK XML file, up to where cut(text read so far) says
// (npos: read on; the whole file when it never says).
template <class Cut> std::string xml_head(const char *path, Cut cut)
{
    FILE *f = std::fopen(path, "rb");
    if (!f)
        throw ivexp::Error(std::string("cannot read ") + path + ": " + std::strerror(errno));
    std::string head;
    char buf[65536];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) {
        head.append(buf, n);
        size_t at = cut(head);
        if (at != std::string::npos) {
            head.resize(at);
            break;
        }
    }
    std::fclose(f);
    return head;
}

// The header of a VTK XML file: everything before its appended data.
std::string xml_header(const char *path)
{
    return xml_head(path, [](const std::string &h) { return h.find("<AppendedData"); });
}

// The start tag of element `name` ("<name ...", without its '>'), read from
// the beginning of path only; "" when the file has none.
std::string xml_start_tag(const char *path, const char *name)
{
    const std::string open = std::string("<") + name + " ";
    std::string head = xml_head(path, [&](const std::string &h) {
        size_t at = h.find(open);
        return at == std::string::npos ? at : h.find('>', at);
    });
    size_t at = head.find(open);
    return at == std::string::npos ? "" : head.substr(at);
}

// The <PDataArray> lines of the DataArrays inside section `section` of head.
std::string parallel_arrays(const std::string &head, const char *section)
{
    std::string open = std::string("<") + section, close = std::string("</") + section + ">";
    size_t from = head.find(open);
    if (from == std::string::npos)
        return "";
    size_t to = head.find(close, from);
    if (to == std::string::npos)
        throw ivexp::Error("a piece's " + std::string(section) + " is not closed");
    std::string out;
    for (size_t at = head.find("<DataArray", from); at != std::string::npos && at < to;
         at = head.find("<DataArray", at + 1)) {
        std::string tag = head.substr(at, head.find('>', at) - at);
        out += "      <PDataArray type=\"" + attribute(tag, "type") + "\"";
        std::string name = attribute(tag, "Name"), comps = attribute(tag, "NumberOfComponents");
        if (!name.empty())
            out += " Name=\"" + name + "\"";
        if (!comps.empty())
            out += " NumberOfComponents=\"" + comps + "\"";
        out += "/>\n";
    }
    return out;
}

void write_all(const char *path, const std::string &text)
{
    ivoct_error_t e;
    ivoct_error_clear(&e);
    io_file_t f;
    if (io_open(&f, path, &e))
        throw ivexp::Error(e.msg);
    if (std::fwrite(text.data(), 1, text.size(), f.f) != text.size()) {
        io_abort(&f);
        throw ivexp::Error(std::string("cannot write ") + path + ": " + std::strerror(errno));
    }
    if (io_commit(&f, &e))
        throw ivexp::Error(e.msg);
}

} // namespace

int exp_pvtu_index(const char *path, const char *piece, const char *const *sources, int n,
                   ivoct_error_t *err)
{
    return ivexp::guard(err, [&] {
        std::string head = xml_header(piece);
        std::string vtkfile = head.substr(0, head.find('>', head.find("<VTKFile")));
        if (vtkfile.find("UnstructuredGrid") == std::string::npos)
            throw ivexp::Error(std::string(piece) + " is not a .vtu piece");
        std::string x = "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"" +
                        attribute(vtkfile, "version") + "\" byte_order=\"" +
                        attribute(vtkfile, "byte_order") + "\" header_type=\"" +
                        attribute(vtkfile, "header_type") + "\">\n"
                        "  <PUnstructuredGrid GhostLevel=\"0\">\n";
        x += "    <PPointData>\n" + parallel_arrays(head, "PointData") + "    </PPointData>\n";
        x += "    <PCellData>\n" + parallel_arrays(head, "CellData") + "    </PCellData>\n";
        x += "    <PPoints>\n" + parallel_arrays(head, "Points") + "    </PPoints>\n";
        for (int i = 0; i < n; i++)
            x += "    <Piece Source=\"" + std::string(sources[i]) + "\"/>\n";
        x += "  </PUnstructuredGrid>\n</VTKFile>\n";
        write_all(path, x);
    });
}

int exp_phtg_index(const char *path, const char *piece, const char *const *sources, int n,
                   ivoct_error_t *err)
{
    return ivexp::guard(err, [&] {
        std::string vtkfile = xml_start_tag(piece, "VTKFile");
        std::string grid = xml_start_tag(piece, "HyperTreeGrid");
        if (attribute(vtkfile, "type") != "HyperTreeGrid" || grid.empty())
            throw ivexp::Error(std::string(piece) + " is not a .htg piece");
        // VTK 9.1's vtkXMLPHyperTreeGridReader sizes its arrays by it (exp_htg_piece)
        if (attribute(grid, "NumberOfVertices").empty())
            throw ivexp::Error(std::string(piece) + " has no NumberOfVertices: not a .phtg piece");
        // what vtkXMLPHyperTreeGridWriter writes: the reader takes nothing else
        // from the index (no array declarations), the grid from the first piece
        std::string x = "<?xml version=\"1.0\"?>\n<VTKFile type=\"PHyperTreeGrid\" "
                        "version=\"0.1\" byte_order=\"" +
                        attribute(vtkfile, "byte_order") + "\" header_type=\"" +
                        attribute(vtkfile, "header_type") + "\">\n  <PHyperTreeGrid>\n";
        for (int i = 0; i < n; i++)
            x += "    <Piece Source=\"" + std::string(sources[i]) + "\"/>\n";
        x += "  </PHyperTreeGrid>\n</VTKFile>\n";
        write_all(path, x);
    });
}

int exp_cells_index(const char *path, const char *const *sources, const uint64_t *leaves, int n,
                    ivoct_error_t *err)
{
    return ivexp::guard(err, [&] {
        uint64_t total = 0;
        for (int i = 0; i < n; i++)
            total += leaves[i];
        std::string x = "# ivoct cell list in " + std::to_string(n) + " pieces, " +
                        std::to_string(total) + " leaves; one piece per line: file,leaves\n";
        for (int i = 0; i < n; i++)
            x += std::string(sources[i]) + "," + std::to_string(leaves[i]) + "\n";
        write_all(path, x);
    });
}
